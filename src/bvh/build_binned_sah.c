/* Binned SAH (Wald 2007) over boxes and centres: the builder knows nothing
 * of triangles (the madmann91/bvh way), so any primitive with a box can use
 * it. Subtrees of large ranges are built on POSIX threads (in glibc's libc
 * itself), up to the thread budget; the tree does not depend on it. Not C11
 * thrd_create: ThreadSanitizer does not intercept it and cannot check it. */
#define _POSIX_C_SOURCE 200809L
#include <math.h>
#include <pthread.h>
#include <stdatomic.h>
#include <string.h>

#include "box3.h"
#include "build_binned_sah.h"

#define MAX_BINS SC_SAH_MAX_BINS
/* Below this depth SAH splits may be arbitrarily unbalanced; from it on the
 * builder splits at the object median, so that at most 31 more levels follow
 * and the binary depth stays below SC_BVH_MAX_DEPTH. */
#define MEDIAN_DEPTH 32

typedef struct sah_builder {
    const box3 *pbox;
    const float (*cen)[3];
    uint32_t *ids;
    sc_bnode *nodes;
    int max_leaf, bins;
    float traversal_cost;
    atomic_int spare;        /* threads that may still be started */
} sah_builder;

static void swap_ids(uint32_t *ids, size_t i, size_t j)
{
    uint32_t t = ids[i];
    ids[i] = ids[j];
    ids[j] = t;
}

/* Quickselect: ids[begin..end) partitioned around the element of rank mid by
 * centroid coordinate on axis (ties broken by id, so the result is
 * deterministic). */
static int cen_less(const sah_builder *B, uint32_t x, uint32_t y, int axis)
{
    float a = B->cen[x][axis], b = B->cen[y][axis];
    return a < b || (a == b && x < y);
}

static void select_median(sah_builder *B, size_t begin, size_t end, size_t mid, int axis)
{
    uint32_t *ids = B->ids;
    while (end - begin > 1) {
        size_t p = begin + (end - begin) / 2;
        swap_ids(ids, p, end - 1);
        uint32_t pivot = ids[end - 1];
        size_t store = begin;
        for (size_t i = begin; i < end - 1; i++)
            if (cen_less(B, ids[i], pivot, axis))
                swap_ids(ids, i, store++);
        swap_ids(ids, store, end - 1);
        if (store == mid)
            return;
        if (mid < store)
            end = store;
        else
            begin = store + 1;
    }
}

/* The subtree over ids[begin..end) goes into nodes[me ..): its node is me,
 * the left subtree (nl primitives) starts at me + 1 and the right one at
 * me + 2 nl, since a subtree of m primitives has at most 2m - 1 nodes. So
 * every node's index follows from the splits alone, whichever thread builds
 * which subtree and in what order: the tree is the same for any thread
 * count (unused slots stay unused). */
static void build_range(sah_builder *B, size_t begin, size_t end, int depth, uint32_t me, box3 bounds,
                        box3 cb);

typedef struct subtree_job {
    sah_builder *B;
    size_t begin, end;
    int depth;
    uint32_t me;
    box3 bounds, cb;
} subtree_job;

static void *subtree_thread(void *arg)
{
    subtree_job *j = arg;
    build_range(j->B, j->begin, j->end, j->depth, j->me, j->bounds, j->cb);
    return NULL;
}

/* The box of the primitives ids[begin..end) and of their centres. */
static void range_bounds(const sah_builder *B, size_t begin, size_t end, box3 *bounds, box3 *cb)
{
    box_empty(bounds);
    box_empty(cb);
    for (size_t i = begin; i < end; i++) {
        uint32_t t = B->ids[i];
        box_grow(bounds, &B->pbox[t]);
        box3 c = { { B->cen[t][0], B->cen[t][1], B->cen[t][2] },
                   { B->cen[t][0], B->cen[t][1], B->cen[t][2] } };
        box_grow(cb, &c);
    }
}

/* One more thread for a subtree, if the budget allows; 1 if taken. */
static int take_thread(sah_builder *B)
{
    int n = atomic_load(&B->spare);
    while (n > 0)
        if (atomic_compare_exchange_weak(&B->spare, &n, n - 1))
            return 1;
    return 0;
}

/* bounds, cb: the box of ids[begin..end) and of their centres (the parent
 * knows them from its bins and its partition pass: no pass of its own). */
static void build_range(sah_builder *B, size_t begin, size_t end, int depth, uint32_t me, box3 bounds,
                        box3 cb)
{
    sc_bnode *node = &B->nodes[me];
    size_t n = end - begin;
    node->box = bounds;

    const size_t N = (size_t)B->max_leaf;
    const float area = box_area(&bounds);
    if (n <= 1) {
        node->leaf = 1, node->a = (uint32_t)begin, node->b = (uint32_t)n;
        return;
    }

    /* Best binned split over the three axes, binned in one pass over the
     * primitives (each is read once, not once per axis; the bins and the
     * order of the box_grow calls per bin are those of three passes). */
    const int nb = B->bins;
    float best_cost = INFINITY;
    int best_axis = -1, best_bin = 0;
    box3 best_lbox, best_rbox;           /* the two sides' boxes of the best split */
    if (depth < MEDIAN_DEPTH) {
        float scale[3];
        int live[3];
        for (int axis = 0; axis < 3; axis++) {
            float ext = cb.hi[axis] - cb.lo[axis];
            live[axis] = ext > 0;
            scale[axis] = live[axis] ? (float)nb * (1 - 0x1p-20f) / ext : 0;
        }
        box3 bb[3][MAX_BINS];
        size_t cnt[3][MAX_BINS];
        for (int axis = 0; axis < 3; axis++)
            for (int k = 0; k < nb; k++) {
                box_empty(&bb[axis][k]);
                cnt[axis][k] = 0;
            }
        for (size_t i = begin; i < end; i++) {
            uint32_t t = B->ids[i];
            const box3 *pb = &B->pbox[t];
            for (int axis = 0; axis < 3; axis++) {
                int k = (int)((B->cen[t][axis] - cb.lo[axis]) * scale[axis]);
                k = k < 0 ? 0 : k >= nb ? nb - 1 : k;
                cnt[axis][k]++;
                box_grow(&bb[axis][k], pb);
            }
        }
        for (int axis = 0; axis < 3; axis++) {
            if (!live[axis])
                continue;
            float rarea[MAX_BINS];
            size_t rcnt[MAX_BINS];
            box3 rbox[MAX_BINS];
            box3 acc;
            box_empty(&acc);
            size_t c = 0;
            for (int k = nb - 1; k > 0; k--) {
                box_grow(&acc, &bb[axis][k]);
                c += cnt[axis][k];
                rarea[k] = box_area(&acc);
                rcnt[k] = c;
                rbox[k] = acc;
            }
            box_empty(&acc);
            c = 0;
            for (int k = 0; k < nb - 1; k++) {
                box_grow(&acc, &bb[axis][k]);
                c += cnt[axis][k];
                if (c == 0 || rcnt[k + 1] == 0)
                    continue;
                float cost = box_area(&acc) * leaf_blocks(c) + rarea[k + 1] * leaf_blocks(rcnt[k + 1]);
                if (cost < best_cost) {
                    best_cost = cost;
                    best_axis = axis;
                    best_bin = k;
                    best_lbox = acc;
                    best_rbox = rbox[k + 1];
                }
            }
        }
    }

    float leaf_cost = area * leaf_blocks(n);
    float split_cost = B->traversal_cost * area + best_cost;
    if (n <= N && (best_axis < 0 || leaf_cost <= split_cost)) {
        node->leaf = 1, node->a = (uint32_t)begin, node->b = (uint32_t)n;
        return;
    }

    size_t mid;
    box3 lb, lcb, rb, rcb;               /* the children's boxes and centre boxes */
    int known = 0;
    if (best_axis >= 0) {
        float ext = cb.hi[best_axis] - cb.lo[best_axis];
        float scale = (float)nb * (1 - 0x1p-20f) / ext;
        box_empty(&lcb);
        box_empty(&rcb);
        size_t i = begin, j = end;
        while (i < j) {
            uint32_t t = B->ids[i];
            box3 c = { { B->cen[t][0], B->cen[t][1], B->cen[t][2] },
                       { B->cen[t][0], B->cen[t][1], B->cen[t][2] } };
            int k = (int)((B->cen[t][best_axis] - cb.lo[best_axis]) * scale);
            k = k < 0 ? 0 : k >= nb ? nb - 1 : k;
            if (k <= best_bin) {
                box_grow(&lcb, &c);
                i++;
            } else {
                box_grow(&rcb, &c);
                swap_ids(B->ids, i, --j);
            }
        }
        mid = i;
        lb = best_lbox, rb = best_rbox;
        known = 1;
    } else {
        /* Deep, or all centroids equal: object median on the widest axis. */
        int axis = 0;
        for (int k = 1; k < 3; k++)
            if (cb.hi[k] - cb.lo[k] > cb.hi[axis] - cb.lo[axis])
                axis = k;
        mid = begin + n / 2;
        select_median(B, begin, end, mid, axis);
    }
    if (mid == begin || mid == end) {
        mid = begin + n / 2;
        known = 0;
    }
    if (!known) {
        range_bounds(B, begin, mid, &lb, &lcb);
        range_bounds(B, mid, end, &rb, &rcb);
    }
    const uint32_t l = me + 1, r = me + 2 * (uint32_t)(mid - begin);
    node->leaf = 0, node->a = l, node->b = r;
    /* Large subtrees: the left one on another thread when the budget has
     * one; the two write disjoint id ranges and node ranges. */
    pthread_t th;
    subtree_job job = { B, begin, mid, depth + 1, l, lb, lcb };
    int took = n >= SC_SAH_PARALLEL_MIN && take_thread(B);
    int spawned = took && pthread_create(&th, NULL, subtree_thread, &job) == 0;
    if (took && !spawned)
        atomic_fetch_add(&B->spare, 1);     /* no thread after all: give it back */
    if (!spawned)
        build_range(B, begin, mid, depth + 1, l, lb, lcb);
    build_range(B, mid, end, depth + 1, r, rb, rcb);
    if (spawned) {
        pthread_join(th, NULL);
        atomic_fetch_add(&B->spare, 1);
    }
}

uint32_t sc_build_binned_sah(const box3 *boxes, const float (*centres)[3], uint32_t *ids, size_t n,
                             const sc_sah_params *p, sc_bnode *nodes, size_t *node_count)
{
    sah_builder B = { boxes, centres, ids, nodes, p->max_leaf, p->bins, p->traversal_cost, 0 };
    atomic_init(&B.spare, p->threads > 1 ? p->threads - 1 : 0);
    box3 bounds, cb;
    range_bounds(&B, 0, n, &bounds, &cb);
    build_range(&B, 0, n, 0, 0, bounds, cb);
    *node_count = 2 * n - 1;
    return 0;
}

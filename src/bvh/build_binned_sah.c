/* Binned SAH (Wald 2007) over boxes and centres: the builder knows nothing
 * of triangles (the madmann91/bvh way), so any primitive with a box can use
 * it. Subtrees of large ranges are tasks for a pool of POSIX threads (in
 * glibc's libc itself); the tree does not depend on which thread builds
 * what. Not C11 thrd_create: ThreadSanitizer does not intercept it and
 * cannot check it. */
#define _POSIX_C_SOURCE 200809L
#include <math.h>
#include <pthread.h>
#include <stdlib.h>
#include <string.h>

#include "box3.h"
#include "build_binned_sah.h"
#include "build_internal.h"
#include "vbox.h"


#define MAX_BINS SC_SAH_MAX_BINS
#define MEDIAN_DEPTH SC_SAH_MEDIAN_DEPTH

struct subtree_job;

typedef struct sah_builder {
    box3 *pbox;              /* pbox[i]: the box of ids[i] */
    uint32_t *ids;
    sc_bnode *nodes;
    int max_leaf, bins;
    float traversal_cost;
    /* The task pool (threads > 1): the left subtrees of ranges of at
     * least SC_SAH_PARALLEL_MIN primitives wait in a queue, oldest
     * (largest) first, for whichever thread is free; `unfinished` counts
     * the tasks queued or running. */
    int pool;
    pthread_mutex_t lock;
    pthread_cond_t wake;
    struct subtree_job *queue;
    size_t head, tail, unfinished;
} sah_builder;

/* The boxes move with their ids: every pass over a range reads two
 * sequential streams, not boxes scattered by the id order. */
static void swap_prims(sah_builder *B, size_t i, size_t j)
{
    uint32_t t = B->ids[i];
    B->ids[i] = B->ids[j];
    B->ids[j] = t;
    box3 b = B->pbox[i];
    B->pbox[i] = B->pbox[j];
    B->pbox[j] = b;
}

/* Quickselect: ids[begin..end) partitioned around the element of rank mid by
 * centroid coordinate on axis (ties broken by id, so the result is
 * deterministic). */
static void select_median(sah_builder *B, size_t begin, size_t end, size_t mid, int axis)
{
    while (end - begin > 1) {
        size_t p = begin + (end - begin) / 2;
        swap_prims(B, p, end - 1);
        const uint32_t pid = B->ids[end - 1];
        const float pc = centre_of(&B->pbox[end - 1], axis);
        size_t store = begin;
        for (size_t i = begin; i < end - 1; i++) {
            const float c = centre_of(&B->pbox[i], axis);
            if (c < pc || (c == pc && B->ids[i] < pid))
                swap_prims(B, i, store++);
        }
        swap_prims(B, store, end - 1);
        if (store == mid)
            return;
        if (mid < store)
            end = store;
        else
            begin = store + 1;
    }
}

/* Whether primitive i's centre falls in bin `split` or below on `axis`:
 * the bin vbin gives it in the binning (the same operations; the project
 * compiles with -ffp-contract=off, so no multiply-add fuses here and not
 * there). */
static inline int goes_left(const sah_builder *B, size_t i, int axis, float lo, float scale, int nb, int split)
{
    return vbin1(centre_of(&B->pbox[i], axis), lo, scale, nb) <= split;
}

enum { PART_BLOCK = 64 };

/* One block of partition_bins: the PART_BLOCK primitives from `first` on
 * (step 1, the left block) or down (step -1, the right block). Lists in
 * off[] the offsets of those on the wrong side (right in the left block,
 * left in the right one) and returns their number; grows lc and rc by
 * every centre. */
static inline size_t scan_block(const sah_builder *B, size_t first, int step, int axis, float lo, float scale,
                                int split, unsigned char *off, vbox *lc, vbox *rc)
{
    size_t k = 0;
    for (int t = 0; t < PART_BLOCK; t++) {
        const size_t i = step > 0 ? first + (size_t)t : first - (size_t)t;
        const int left = goes_left(B, i, axis, lo, scale, B->bins, split);
        const vpoint c = vbox_centre(vbox_load(&B->pbox[i]));
        vbox_grow_point_if(lc, c, left);
        vbox_grow_point_if(rc, c, !left);
        off[k] = (unsigned char)t;
        k += (size_t)(left != (step > 0));
    }
    return k;
}

/* Moves the primitives of [begin, end) whose centre's bin is `split` or
 * below before the others and returns where the others start; grows lc
 * and rc by the two sides' centres. Blocks of PART_BLOCK primitives from
 * both ends are classified without a branch into lists of the misplaced
 * ones, which are then swapped in pairs (BlockQuicksort, Edelkamp and
 * Weiss 2016): a branch on each primitive's side mispredicts wherever
 * the two sides mix (with the branch-free binning, the SAH step of the 8M
 * grid 3.5 -> 3.1 s, docs/compare.md). The few primitives left
 * between the blocks go by the plain two-ended loop. A centre may be
 * grown into its side twice (a block's remainder is seen again): min and
 * max do not mind. */
static size_t partition_bins(sah_builder *B, size_t begin, size_t end, int axis, float lo, float scale,
                             int split, vbox *lc, vbox *rc)
{
    const int nb = B->bins;
    size_t i = begin, j = end;
    unsigned char offl[PART_BLOCK], offr[PART_BLOCK];
    size_t nl = 0, nr = 0, sl = 0, sr = 0;
    while (j - i >= 2 * PART_BLOCK) {
        if (nl == 0)
            sl = 0, nl = scan_block(B, i, 1, axis, lo, scale, split, offl, lc, rc);
        if (nr == 0)
            sr = 0, nr = scan_block(B, j - 1, -1, axis, lo, scale, split, offr, lc, rc);
        const size_t m = nl < nr ? nl : nr;
        for (size_t t = 0; t < m; t++)
            swap_prims(B, i + offl[sl + t], j - 1 - offr[sr + t]);
        nl -= m, nr -= m, sl += m, sr += m;
        if (nl == 0)
            i += PART_BLOCK;
        if (nr == 0)
            j -= PART_BLOCK;
    }
    while (i < j) {
        const vpoint c = vbox_centre(vbox_load(&B->pbox[i]));
        if (goes_left(B, i, axis, lo, scale, nb, split)) {
            vbox_grow_point(lc, c);
            i++;
        } else {
            vbox_grow_point(rc, c);
            swap_prims(B, i, --j);
        }
    }
    return i;
}

/* The subtree over ids[begin..end) goes into nodes[me ..). A range of
 * SC_SAH_PARALLEL_MIN primitives or more owns the slots [me, me + 2n - 1)
 * (a subtree of m primitives has at most 2m - 1 nodes): the left subtree's
 * start at me + 1 and the right one's at me + 2 nl, so these nodes' indices
 * follow from the splits alone, whichever thread builds which subtree. A
 * smaller range is built on one thread and numbers its descendants densely
 * from *next (the slot after its first small ancestor), in the order of the
 * recursion. So the tree is the same for any thread count, and the nodes
 * touch the pages of the slots they use, not of all 2n - 1 (a fresh page
 * costs its first touch). `next` is NULL for the large ranges. */
static void build_range(sah_builder *B, size_t begin, size_t end, int depth, uint32_t me, uint32_t *next,
                        box3 bounds, box3 cb);

typedef struct subtree_job {
    size_t begin, end;
    int depth;
    uint32_t me;
    box3 bounds, cb;
} subtree_job;

/* At most this many tasks are ever queued for n primitives: a task is
 * queued by a range of at least SC_SAH_PARALLEL_MIN primitives; the ranges
 * of one tree level are disjoint, so a level has at most
 * n / SC_SAH_PARALLEL_MIN of them, and such ranges occur on at most
 * MEDIAN_DEPTH SAH levels plus 32 levels of median splits below them. */
static size_t max_tasks(size_t n)
{
    return (n / SC_SAH_PARALLEL_MIN) * (MEDIAN_DEPTH + 32) + 1;
}

static void push_task(sah_builder *B, const subtree_job *j)
{
    pthread_mutex_lock(&B->lock);
    B->queue[B->tail++] = *j;
    B->unfinished++;
    pthread_cond_signal(&B->wake);
    pthread_mutex_unlock(&B->lock);
}

static void *pool_worker(void *arg)
{
    sah_builder *B = arg;
    pthread_mutex_lock(&B->lock);
    for (;;) {
        while (B->head == B->tail && B->unfinished > 0)
            pthread_cond_wait(&B->wake, &B->lock);
        if (B->head == B->tail)
            break;                                  /* no task queued or running: done */
        const subtree_job j = B->queue[B->head++];
        pthread_mutex_unlock(&B->lock);
        uint32_t next = j.me + 1;
        build_range(B, j.begin, j.end, j.depth, j.me, j.end - j.begin < SC_SAH_PARALLEL_MIN ? &next : NULL, j.bounds,
                    j.cb);
        pthread_mutex_lock(&B->lock);
        if (--B->unfinished == 0)
            pthread_cond_broadcast(&B->wake);
    }
    pthread_mutex_unlock(&B->lock);
    return NULL;
}

/* The box of the primitives ids[begin..end) and of their centres. */
static void range_bounds(const sah_builder *B, size_t begin, size_t end, box3 *bounds, box3 *cb)
{
    vbox b = vbox_empty(), c = vbox_empty();
    for (size_t i = begin; i < end; i++) {
        const vbox p = vbox_load(&B->pbox[i]);
        vbox_grow(&b, p);
        vbox_grow_point(&c, vbox_centre(p));
    }
    *bounds = vbox_box(b);
    *cb = vbox_box(c);
}

/* bounds, cb: the box of ids[begin..end) and of their centres (the parent
 * knows them from its bins and its partition pass: no pass of its own). */
static void build_range(sah_builder *B, size_t begin, size_t end, int depth, uint32_t me, uint32_t *next,
                        box3 bounds, box3 cb)
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
    vbox best_lbox = vbox_empty(), best_rbox = vbox_empty();   /* the sides of the best split */
    if (depth < MEDIAN_DEPTH) {
        float scale[3];
        int live[3];
        for (int axis = 0; axis < 3; axis++) {
            float ext = cb.hi[axis] - cb.lo[axis];
            live[axis] = ext > 0;
            scale[axis] = live[axis] ? (float)nb * (1 - 0x1p-20f) / ext : 0;
        }
        /* Every bin starts empty (growing an empty box by a finite one
         * gives its bits) and the binning has no branch: with bins set up
         * by their first primitive, the test of whether a bin was used yet
         * mispredicted in the small ranges that most nodes have (with the
         * block partition, the SAH step of the 8M grid 3.5 -> 3.1 s,
         * docs/compare.md). `used` marks the bins the sweep visits. */
        _Static_assert(MAX_BINS <= 64, "the used-bin masks are 64 bits");
        vbox vb[3][MAX_BINS];
        size_t cnt[3][MAX_BINS];
        uint64_t used[3] = { 0, 0, 0 };
        for (int axis = 0; axis < 3; axis++)
            for (int kk = 0; kk < nb; kk++)
                vb[axis][kk] = vbox_empty(), cnt[axis][kk] = 0;
        const vpoint vlo = v3(cb.lo), vscale = v3(scale);
        for (size_t i = begin; i < end; i++) {
            const vbox p = vbox_load(&B->pbox[i]);
            int k[4];
            vbin(vbox_centre(p), vlo, vscale, nb, k);
            for (int axis = 0; axis < 3; axis++) {
                cnt[axis][k[axis]]++;
                vbox_grow(&vb[axis][k[axis]], p);
                used[axis] |= 1ull << k[axis];
            }
        }
        for (int axis = 0; axis < 3; axis++) {
            if (!live[axis])
                continue;
            /* Only the splits right after a non-empty bin: a split after an
             * empty bin has the sides and the cost of the one before it,
             * which comes first and wins the strict compare. So the tree is
             * that of the sweep over every bin, and the small ranges (most
             * nodes) sweep a few bins, not all of them. */
            int idx[MAX_BINS], m = 0;
            for (uint64_t u = used[axis]; u; u &= u - 1)
                idx[m++] = __builtin_ctzll(u);
            float rarea[MAX_BINS];
            size_t rcnt[MAX_BINS];
            vbox rbox[MAX_BINS];
            vbox acc = vbox_empty();
            size_t c = 0;
            for (int j = m - 1; j > 0; j--) {
                vbox_grow(&acc, vb[axis][idx[j]]);
                c += cnt[axis][idx[j]];
                rarea[j] = vbox_area(acc);
                rcnt[j] = c;
                rbox[j] = acc;
            }
            acc = vbox_empty();
            c = 0;
            for (int j = 0; j < m - 1; j++) {
                vbox_grow(&acc, vb[axis][idx[j]]);
                c += cnt[axis][idx[j]];
                float cost = vbox_area(acc) * leaf_blocks(c) + rarea[j + 1] * leaf_blocks(rcnt[j + 1]);
                if (cost < best_cost) {
                    best_cost = cost;
                    best_axis = axis;
                    best_bin = idx[j];
                    best_lbox = acc;
                    best_rbox = rbox[j + 1];
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
        vbox vl = vbox_empty(), vr = vbox_empty();
        mid = partition_bins(B, begin, end, best_axis, cb.lo[best_axis], scale, best_bin, &vl, &vr);
        lcb = vbox_box(vl), rcb = vbox_box(vr);
        lb = vbox_box(best_lbox), rb = vbox_box(best_rbox);
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
    if (next) {
        const uint32_t l = (*next)++, r = (*next)++;
        node->leaf = 0, node->a = l, node->b = r;
        build_range(B, begin, mid, depth + 1, l, next, lb, lcb);
        build_range(B, mid, end, depth + 1, r, next, rb, rcb);
        return;
    }
    const uint32_t l = me + 1, r = me + 2 * (uint32_t)(mid - begin);
    node->leaf = 0, node->a = l, node->b = r;
    uint32_t lnext = l + 1, rnext = r + 1;
    /* A large range: its left subtree a task for the pool; the two write
     * disjoint id ranges and node ranges. */
    if (B->pool) {
        const subtree_job job = { begin, mid, depth + 1, l, lb, lcb };
        push_task(B, &job);
    } else {
        build_range(B, begin, mid, depth + 1, l, mid - begin < SC_SAH_PARALLEL_MIN ? &lnext : NULL, lb, lcb);
    }
    build_range(B, mid, end, depth + 1, r, end - mid < SC_SAH_PARALLEL_MIN ? &rnext : NULL, rb, rcb);
}

uint32_t sc_build_binned_sah(box3 *boxes, uint32_t *ids, size_t n, const sc_sah_params *p, sc_bnode *nodes,
                             size_t *node_count)
{
    sah_builder B;
    memset(&B, 0, sizeof B);
    B.pbox = boxes, B.ids = ids, B.nodes = nodes;
    B.max_leaf = p->max_leaf, B.bins = p->bins, B.traversal_cost = p->traversal_cost;
    box3 bounds, cb;
    range_bounds(&B, 0, n, &bounds, &cb);
    const subtree_job root = { 0, n, 0, 0, bounds, cb };
    if (p->threads > 1 && n >= SC_SAH_PARALLEL_MIN && (B.queue = malloc(sizeof(subtree_job) * max_tasks(n)))) {
        B.pool = 1;
        pthread_mutex_init(&B.lock, NULL);
        pthread_cond_init(&B.wake, NULL);
        B.queue[B.tail++] = root;
        B.unfinished = 1;
        sc_build_run_workers(pool_worker, &B, p->threads, (size_t)p->threads);
        pthread_mutex_destroy(&B.lock);
        pthread_cond_destroy(&B.wake);
        free(B.queue);
    } else {
        uint32_t next = 1;   /* one thread, or no memory for the queue */
        build_range(&B, 0, n, 0, 0, n < SC_SAH_PARALLEL_MIN ? &next : NULL, bounds, cb);
    }
    *node_count = 2 * n - 1;
    return 0;
}

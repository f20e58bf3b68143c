/* Binned SAH (Wald 2007) over boxes and centres: the builder knows nothing
 * of triangles (the madmann91/bvh way), so any primitive with a box can use
 * it. Single-threaded. */
#include <math.h>
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
    size_t count;
    int max_leaf, bins;
    float traversal_cost;
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

static uint32_t build_range(sah_builder *B, size_t begin, size_t end, int depth)
{
    uint32_t me = (uint32_t)B->count++;
    sc_bnode *node = &B->nodes[me];
    size_t n = end - begin;
    box3 bounds, cb;
    box_empty(&bounds);
    box_empty(&cb);
    for (size_t i = begin; i < end; i++) {
        uint32_t t = B->ids[i];
        box_grow(&bounds, &B->pbox[t]);
        box3 c = { { B->cen[t][0], B->cen[t][1], B->cen[t][2] },
                   { B->cen[t][0], B->cen[t][1], B->cen[t][2] } };
        box_grow(&cb, &c);
    }
    node->box = bounds;

    const size_t N = (size_t)B->max_leaf;
    const float area = box_area(&bounds);
    if (n <= 1) {
        node->leaf = 1, node->a = (uint32_t)begin, node->b = (uint32_t)n;
        return me;
    }

    /* Best binned split over the three axes. */
    const int nb = B->bins;
    float best_cost = INFINITY;
    int best_axis = -1, best_bin = 0;
    if (depth < MEDIAN_DEPTH) {
        for (int axis = 0; axis < 3; axis++) {
            float ext = cb.hi[axis] - cb.lo[axis];
            if (!(ext > 0))
                continue;
            float scale = (float)nb * (1 - 0x1p-20f) / ext;
            box3 bb[MAX_BINS];
            size_t cnt[MAX_BINS] = { 0 };
            for (int k = 0; k < nb; k++)
                box_empty(&bb[k]);
            for (size_t i = begin; i < end; i++) {
                uint32_t t = B->ids[i];
                int k = (int)((B->cen[t][axis] - cb.lo[axis]) * scale);
                k = k < 0 ? 0 : k >= nb ? nb - 1 : k;
                cnt[k]++;
                box_grow(&bb[k], &B->pbox[t]);
            }
            float rarea[MAX_BINS];
            size_t rcnt[MAX_BINS];
            box3 acc;
            box_empty(&acc);
            size_t c = 0;
            for (int k = nb - 1; k > 0; k--) {
                box_grow(&acc, &bb[k]);
                c += cnt[k];
                rarea[k] = box_area(&acc);
                rcnt[k] = c;
            }
            box_empty(&acc);
            c = 0;
            for (int k = 0; k < nb - 1; k++) {
                box_grow(&acc, &bb[k]);
                c += cnt[k];
                if (c == 0 || rcnt[k + 1] == 0)
                    continue;
                float cost = box_area(&acc) * leaf_blocks(c) + rarea[k + 1] * leaf_blocks(rcnt[k + 1]);
                if (cost < best_cost) {
                    best_cost = cost;
                    best_axis = axis;
                    best_bin = k;
                }
            }
        }
    }

    float leaf_cost = area * leaf_blocks(n);
    float split_cost = B->traversal_cost * area + best_cost;
    if (n <= N && (best_axis < 0 || leaf_cost <= split_cost)) {
        node->leaf = 1, node->a = (uint32_t)begin, node->b = (uint32_t)n;
        return me;
    }

    size_t mid;
    if (best_axis >= 0) {
        float ext = cb.hi[best_axis] - cb.lo[best_axis];
        float scale = (float)nb * (1 - 0x1p-20f) / ext;
        size_t i = begin, j = end;
        while (i < j) {
            uint32_t t = B->ids[i];
            int k = (int)((B->cen[t][best_axis] - cb.lo[best_axis]) * scale);
            k = k < 0 ? 0 : k >= nb ? nb - 1 : k;
            if (k <= best_bin)
                i++;
            else
                swap_ids(B->ids, i, --j);
        }
        mid = i;
    } else {
        /* Deep, or all centroids equal: object median on the widest axis. */
        int axis = 0;
        for (int k = 1; k < 3; k++)
            if (cb.hi[k] - cb.lo[k] > cb.hi[axis] - cb.lo[axis])
                axis = k;
        mid = begin + n / 2;
        select_median(B, begin, end, mid, axis);
    }
    if (mid == begin || mid == end)
        mid = begin + n / 2;
    uint32_t l = build_range(B, begin, mid, depth + 1);
    uint32_t r = build_range(B, mid, end, depth + 1);
    node = &B->nodes[me];
    node->leaf = 0, node->a = l, node->b = r;
    return me;
}

uint32_t sc_build_binned_sah(const box3 *boxes, const float (*centres)[3], uint32_t *ids, size_t n,
                             const sc_sah_params *p, sc_bnode *nodes, size_t *node_count)
{
    sah_builder B = { boxes, centres, ids, nodes, 0, p->max_leaf, p->bins, p->traversal_cost };
    uint32_t root = build_range(&B, 0, n, 0);
    *node_count = B.count;
    return root;
}

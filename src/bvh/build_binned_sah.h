/* Binned SAH build of a binary tree over primitive boxes and centres. */
#ifndef SPHERECULL_BVH_BUILD_BINNED_SAH_H
#define SPHERECULL_BVH_BUILD_BINNED_SAH_H

#include <stddef.h>
#include <stdint.h>

#include "box3.h"

#define SC_SAH_MAX_BINS 64
/* Below this depth SAH splits may be arbitrarily unbalanced; from it on a
 * builder splits at the object median, so that at most 31 more levels follow
 * and the binary depth stays below SC_BVH_MAX_DEPTH. */
#define SC_SAH_MEDIAN_DEPTH 32

/* A binary node: inner (a, b = children) or leaf (a = first index into the
 * id array, b = count). */
typedef struct sc_bnode {
    box3 box;
    uint32_t a, b;
    int leaf;
} sc_bnode;

typedef struct sc_sah_params {
    int max_leaf;            /* most primitives per leaf */
    int bins;                /* 4..SC_SAH_MAX_BINS */
    float traversal_cost;    /* of a node visit, in leaf-block tests */
    int threads;             /* most threads building at once (>= 1; the caller's included) */
} sc_sah_params;

/* Ranges smaller than this are not worth a task for another thread. */
#define SC_SAH_PARALLEL_MIN 65536

/* boxes[i] is the box of ids[i] (finite; its centre, by which it is
 * binned, is 0.5 lo + 0.5 hi); the two arrays (n >= 1) are permuted
 * together so that every leaf is a contiguous range of ids; nodes needs
 * room for 2n - 1 (*node_count; some slots stay unused). The same tree,
 * node indices included, for any p->threads. Returns the root's index (0). */
uint32_t sc_build_binned_sah(box3 *boxes, uint32_t *ids, size_t n, const sc_sah_params *p, sc_bnode *nodes,
                             size_t *node_count);

#endif

/* SAH build with spatial splits (SBVH, Stich, Friedrich and Dietrich
 * 2009) over primitive references: a primitive may be cut by a plane into
 * two references, one on each side, each with the box of its part. */
#ifndef SPHERECULL_BVH_BUILD_SPATIAL_SAH_H
#define SPHERECULL_BVH_BUILD_SPATIAL_SAH_H

#include <stddef.h>
#include <stdint.h>

#include "box3.h"
#include "build_binned_sah.h"

/* The part of primitive id inside *box, cut by the plane x[axis] = pos:
 * *left and *right receive boxes that contain the part on each side
 * (conservative: the primitive's points in *box with x[axis] <= pos lie in
 * *left, those with x[axis] >= pos in *right), each inside *box and on its
 * side; an empty side has lo > hi on some axis. The builder knows
 * primitives only through this function and their boxes. */
typedef void (*sc_split_fn)(const void *ctx, uint32_t id, const box3 *box, int axis, float pos, box3 *left,
                            box3 *right);

typedef struct sc_spatial_params {
    sc_sah_params sah;       /* as for the binned SAH (threads is ignored: one thread) */
    float overlap_root;      /* try spatial splits only where the best object split's two boxes
                                overlap by at least this share of the root's area */
    float overlap_node;      /* and by at least this share of the node's own area */
    float budget;            /* at most budget * n references more than primitives */
    int bins;                /* spatial bins per axis (2..SC_SAH_MAX_BINS) */
    sc_split_fn split;
    const void *ctx;
} sc_spatial_params;

/* A binary tree over boxes[i] (the box of primitive ids[i], finite), n >= 1:
 * *ids_out (malloc'd, *refs_out entries, a primitive at most once per leaf)
 * holds every leaf's references as the contiguous range the leaf names;
 * *nodes_out (malloc'd, *node_count slots, root 0) the nodes, whose boxes
 * contain the parts of their primitives that their leaves hold. The same
 * tree on every run. Returns 0, or -1 when out of memory (nothing to free). */
int sc_build_spatial_sah(const box3 *boxes, const uint32_t *ids, size_t n, const sc_spatial_params *p,
                         uint32_t **ids_out, size_t *refs_out, sc_bnode **nodes_out, size_t *node_count);

#endif

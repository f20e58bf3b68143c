/* The BVH handle: what the builder (src/bvh) leaves for the traversal
 * (src/trace). The node and leaf layouts are in node_bvh8.h and
 * leaf_block.h. The handle holds no kernels: which traversal runs is the
 * ISA dispatch's choice (src/isa), made once for the process. */
#ifndef SPHERECULL_BVH_INTERNAL_H
#define SPHERECULL_BVH_INTERNAL_H

#include <stddef.h>
#include <stdint.h>

#include "leaf_block.h"
#include "node_bvh8.h"
#include "spherecull/sc_bvh.h"

struct sc_bvh {
    sc_bvh_node8 *nodes;         /* the root is nodes[0] (always an inner node) */
    unsigned char *leaves;
    int has_root;                /* 0: no triangles, every ray misses */
    float root_lo[3], root_hi[3];
    size_t node_count, leaf_count, leaf_bytes, sphere_bytes, leaves_with_spheres;
    size_t triangles, skipped;
    int depth;
    double sah_cost, build_seconds;
    sc_bvh_config cfg;
};

#endif

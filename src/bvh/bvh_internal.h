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
    unsigned char *leaves;       /* in the nodes' block, after them */
    int has_root;                /* 0: no triangles, every ray misses */
    float root_lo[3], root_hi[3];
    size_t node_count, leaf_count, leaf_bytes, sphere_bytes, leaves_with_spheres;
    size_t triangles, skipped;
    sc_build_quality quality;    /* the one built (cfg.quality, or AUTO's choice) */
    size_t references;           /* triangles in the leaves, counted once per leaf: more than
                                    triangles where the high quality's spatial splits cut some */
    int depth;
    int prefetch;                /* sc_prefetch_level: which traversals prefetch the children they push */
    int interleave;              /* streams trace their incoherent rays interleaved (SC_INTERLEAVE_BYTES) */
    double sah_cost, build_seconds;
    double built_sah_cost;       /* sah_cost when built; a refit changes sah_cost only */
    sc_bvh_config cfg;
    size_t mesh_count;           /* the build input: leaf ids are global ids over its meshes, */
    uint32_t *first;             /* mesh g's triangle t is first[g] + t (mesh_count + 1 entries) */
};

/* A traversal in a tree that does not fit in the caches waits for memory
 * at each child it pops. So from these sizes (nodes and leaves) it
 * prefetches the first four cache lines of the children a node pushes (and
 * of the one it goes to, when only one is hit), as Embree does in every
 * tree: closest-hit single rays from 2 MiB (beyond a core's L2), any-hit
 * rays and packets from 8 MiB. Below them the
 * prefetches cost about what they save, and an any-hit ray ends with most
 * of what it pushed never popped. Measured (docs/compare.md, nineteenth
 * session): trees of 19 MB and more gain 2-20 % on every ray kind; trees of
 * 4-6 MB gain 4-9 % on random rays, and their shadow rays lose 0-4 %. */
#ifndef SC_PREFETCH_CLOSEST_BYTES
#define SC_PREFETCH_CLOSEST_BYTES ((size_t)2 << 20)
#endif
#ifndef SC_PREFETCH_ALL_BYTES
#define SC_PREFETCH_ALL_BYTES ((size_t)8 << 20)
#endif
typedef enum sc_prefetch_level { SC_PREFETCH_NONE, SC_PREFETCH_CLOSEST, SC_PREFETCH_ALL } sc_prefetch_level;

/* From this size a stream traces the rays it cannot group into packets
 * several at a time, their memory loads overlapping (traverse_interleaved,
 * traverse_bvh8_single.h). Below it the tree's loads come from the caches
 * and the slots' bookkeeping is not paid back. Random rays, interleaved
 * over one by one (docs/compare.md, twenty-third session): 0.73-0.99 on
 * the shared meshes with trees of 0.2-5.4 MB, 1.09 on the engine's 6.8 MB,
 * 1.33-2.1 on trees of 8.6 MB to 440 MB. */
#ifndef SC_INTERLEAVE_BYTES
#define SC_INTERLEAVE_BYTES ((size_t)6 << 20)
#endif

/* The mesh that holds global triangle id tri (first[] ascending). */
static inline size_t sc_mesh_of(const uint32_t *first, size_t mesh_count, uint32_t tri)
{
    size_t lo = 0, hi = mesh_count;   /* first[lo] <= tri < first[hi] */
    while (hi - lo > 1) {
        size_t mid = (lo + hi) / 2;
        if (first[mid] <= tri)
            lo = mid;
        else
            hi = mid;
    }
    return lo;
}

/* One mesh of a build, refit or scene: layout, arrays present, indices in
 * range (vertices may be non-finite: such triangles are left out).
 * INVALID_ARGUMENT otherwise. */
sc_status sc_bvh_check_mesh(const sc_mesh_view *mesh);

/* The build over several meshes at once (one tree; leaf ids are global
 * ids, sc_bvh.first maps them back): what sc_bvh_build does for one and the
 * scene handle (sc_accel.h) for its meshes. Same checks and errors. */
sc_status sc_bvh_build_set(const sc_mesh_view *meshes, size_t mesh_count, const sc_bvh_config *cfg,
                           sc_bvh **out);
/* The refit of such a tree from the same meshes after their vertices moved
 * (sc_bvh_refit). */
sc_status sc_bvh_refit_set(sc_bvh *bvh, const sc_mesh_view *meshes, size_t mesh_count);

#endif

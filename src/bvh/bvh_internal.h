/* Private layout of the 8-wide BVH, shared by the builder (src/bvh) and the
 * traversal kernels (src/trace).
 *
 * Inner node: the 8 children's boxes as SoA rows lo_x, hi_x, lo_y, hi_y,
 * lo_z, hi_z (so the near/far plane of an axis is one of two rows chosen by
 * the sign of the ray direction), then 8 child references. 256 bytes, four
 * cache lines, like Embree's AABBNode8. Unused slots have an empty box
 * (lo = +inf, hi = -inf), which every slab test misses.
 *
 * Child reference (64 bits):
 *   0                      empty slot
 *   bit 63 clear           inner node; the value is its byte offset in nodes[]
 *   bit 63 set             leaf; bits 0..47 byte offset in leaves[],
 *                          bits 48..51 count-1, bit 52 spheres present
 * Leaf block of width W = 4, 8 or 16 (smallest >= count), W*4-byte aligned:
 *   [spheres: sc_sphere_blockW, only if bit 52]   4W floats
 *   v[vertex 0..2][axis x,y,z][W]                  9W floats
 *   prim[W]                                        W uint32
 * Lanes >= count repeat the last triangle (so they are harmless even when not
 * masked) and have sphere r2 = -1 (always rejected).
 */
#ifndef SPHERECULL_BVH_INTERNAL_H
#define SPHERECULL_BVH_INTERNAL_H

#include <stddef.h>
#include <stdint.h>

#include "spherecull/sc_bvh.h"
#include "spherecull/sc_prefilter.h"
#include "spherecull/sc_rays.h"
#include "spherecull/sc_trace.h"

#define SC_BVH_N 8

typedef struct __attribute__((aligned(64))) sc_bvh_node8 {
    float b[6][SC_BVH_N];    /* lo_x, hi_x, lo_y, hi_y, lo_z, hi_z */
    uint64_t child[SC_BVH_N];
} sc_bvh_node8;
_Static_assert(sizeof(sc_bvh_node8) == 256, "node8 is four cache lines");

#define SC_REF_LEAF (1ull << 63)
#define SC_REF_SPHERES (1ull << 52)
#define SC_REF_OFFSET_MASK ((1ull << 48) - 1)

static inline int sc_ref_is_leaf(uint64_t r) { return (r & SC_REF_LEAF) != 0; }
static inline unsigned sc_ref_count(uint64_t r) { return (unsigned)((r >> 48) & 15) + 1; }
static inline int sc_ref_has_spheres(uint64_t r) { return (r & SC_REF_SPHERES) != 0; }
static inline size_t sc_ref_offset(uint64_t r) { return (size_t)(r & SC_REF_OFFSET_MASK); }
static inline unsigned sc_leaf_width(unsigned count) { return count <= 4 ? 4 : count <= 8 ? 8 : 16; }

/* Maximum depth of the binary build tree (the 8-wide tree is never deeper);
 * deeper ranges are split at the median. Bounds the traversal stack. */
#define SC_BVH_MAX_DEPTH 64
#define SC_TRACE_STACK (SC_BVH_MAX_DEPTH * (SC_BVH_N - 1) + SC_BVH_N)

/* One kernel set: closest/any, with and without statistics. */
typedef struct sc_trace_kernels {
    void (*closest)(const struct sc_bvh *bvh, const sc_ray *ray, sc_hitrec *hit);
    int (*any)(const struct sc_bvh *bvh, const sc_ray *ray);
    void (*closest_stats)(const struct sc_bvh *bvh, const sc_ray *ray, sc_hitrec *hit,
                          sc_trace_stats *st);
    int (*any_stats)(const struct sc_bvh *bvh, const sc_ray *ray, sc_trace_stats *st);
} sc_trace_kernels;

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
    sc_trace_isa isa;
    const sc_trace_kernels *kernels;
};

/* Kernel tables (src/trace). [tri_test] */
extern const sc_trace_kernels sc_trace_kernels_scalar[SC_TRI_TEST_COUNT];
extern const sc_trace_kernels sc_trace_kernels_avx2[SC_TRI_TEST_COUNT];
extern const sc_trace_kernels sc_trace_kernels_avx512[SC_TRI_TEST_COUNT];

/* Chooses the kernel set for an ISA request (AUTO: env + CPU). */
sc_status sc_trace_select(sc_trace_isa want, sc_trace_isa *got);

#endif

/* The 8-wide inner node and the child reference: the layout the builder
 * writes and every traversal reads.
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
 *                          bits 48..51 count-1, bit 52 a float sphere
 *                          block present, bit 53 a compact sphere summary
 *                          present (the leaf block itself: leaf_block.h)
 */
#ifndef SPHERECULL_BVH_NODE_BVH8_H
#define SPHERECULL_BVH_NODE_BVH8_H

#include <stddef.h>
#include <stdint.h>

#define SC_BVH_N 8

typedef struct __attribute__((aligned(64))) sc_bvh_node8 {
    float b[6][SC_BVH_N];    /* lo_x, hi_x, lo_y, hi_y, lo_z, hi_z */
    uint64_t child[SC_BVH_N];
} sc_bvh_node8;
_Static_assert(sizeof(sc_bvh_node8) == 256, "node8 is four cache lines");

#define SC_REF_LEAF (1ull << 63)
#define SC_REF_SPHERES (1ull << 52)
#define SC_REF_SUMMARY (1ull << 53)
#define SC_REF_OFFSET_MASK ((1ull << 48) - 1)

static inline int sc_ref_is_leaf(uint64_t r) { return (r & SC_REF_LEAF) != 0; }
static inline unsigned sc_ref_count(uint64_t r) { return (unsigned)((r >> 48) & 15) + 1; }
static inline int sc_ref_has_spheres(uint64_t r) { return (r & SC_REF_SPHERES) != 0; }
static inline int sc_ref_has_summary(uint64_t r) { return (r & SC_REF_SUMMARY) != 0; }
static inline size_t sc_ref_offset(uint64_t r) { return (size_t)(r & SC_REF_OFFSET_MASK); }

/* flags: 0, SC_REF_SPHERES or SC_REF_SUMMARY */
static inline uint64_t sc_ref_leaf(size_t offset, unsigned count, uint64_t flags)
{
    return SC_REF_LEAF | flags | ((uint64_t)(count - 1) << 48) | (uint64_t)offset;
}

/* Maximum depth of the binary build tree (the 8-wide tree is never deeper);
 * deeper ranges are split at the median. Bounds the traversal stack. */
#define SC_BVH_MAX_DEPTH 64

#endif

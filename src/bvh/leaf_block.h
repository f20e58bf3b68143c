/* The leaf block: up to 16 triangles as pre-gathered SoA vertices (like
 * Embree's triangle4/8), optionally preceded by their prefilter spheres.
 * Every reader and the one writer (leaf_triangles.c) go through these
 * accessors, so the layout is spelled out here only.
 *
 * Block of width W = 4, 8 or 16 (smallest >= count), W*4-byte aligned:
 *   [spheres: sc_sphere_blockW, only if the reference says so]   4W floats
 *   v[vertex 0..2][axis x,y,z][W]                                 9W floats
 *   prim[W]                                                       W uint32
 * Lanes >= count repeat the last triangle (so they are harmless even when not
 * masked) and have sphere r2 = -1 (always rejected).
 */
#ifndef SPHERECULL_BVH_LEAF_BLOCK_H
#define SPHERECULL_BVH_LEAF_BLOCK_H

#include <stddef.h>
#include <stdint.h>

#include "node_bvh8.h"

static inline unsigned sc_leaf_width(unsigned count) { return count <= 4 ? 4 : count <= 8 ? 8 : 16; }

/* Bytes of a block: 4W sphere floats, 9W vertex floats, W ids. */
static inline size_t sc_leaf_bytes(unsigned W, int spheres) { return (size_t)W * 4 * (spheres ? 14 : 10); }

/* The block a leaf reference points at: its sphere block (when it has
 * spheres) and its vertex rows. */
static inline const float *sc_leaf_block(const unsigned char *leaves, uint64_t ref)
{
    return (const float *)(const void *)(leaves + sc_ref_offset(ref));
}
static inline const float *sc_leaf_rows(const float *block, unsigned W, int spheres)
{
    return spheres ? block + 4 * W : block;
}

/* Index of vertex j (0..2), axis k (0..2) of lane i in the vertex rows. */
static inline size_t sc_leaf_at(unsigned W, unsigned j, unsigned k, unsigned i)
{
    return (3 * (size_t)j + k) * W + i;
}

/* The triangle ids after the vertex rows. */
static inline const uint32_t *sc_leaf_prims(const float *rows, unsigned W)
{
    return (const uint32_t *)(const void *)(rows + 9 * W);
}

/* The geometric normal (V1 - V0) x (V2 - V0) of lane i, in float, the
 * operations in this order (no contraction: -ffp-contract=off), so every
 * kernel and ISA reports the same bits. */
static inline void sc_leaf_normal(const float *rows, unsigned W, unsigned i, float ng[3])
{
    float e1[3], e2[3];
    for (unsigned k = 0; k < 3; k++) {
        const float v0 = rows[sc_leaf_at(W, 0, k, i)];
        e1[k] = rows[sc_leaf_at(W, 1, k, i)] - v0;
        e2[k] = rows[sc_leaf_at(W, 2, k, i)] - v0;
    }
    ng[0] = e1[1] * e2[2] - e1[2] * e2[1];
    ng[1] = e1[2] * e2[0] - e1[0] * e2[2];
    ng[2] = e1[0] * e2[1] - e1[1] * e2[0];
}

#endif

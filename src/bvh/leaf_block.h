/* The leaf block: up to 16 triangles as pre-gathered SoA vertices (like
 * Embree's triangle4/8), optionally preceded by their prefilter spheres.
 * Every reader and the one writer (leaf_triangles.c) go through these
 * accessors, so the layout is spelled out here only.
 *
 * Block of width W = 4, 8 or 16 (smallest >= count), W*4-byte aligned:
 *   [spheres: sc_sphere_blockW, if the reference says so]         4W floats
 *   [or the compact summary, if the reference says so]             48, 64, 128 bytes
 *   v[vertex 0..2][axis x,y,z][W]                                 9W floats
 *   prim[W]                                                       W uint32
 * Lanes >= count repeat the last triangle (so they are harmless even when not
 * masked) and have sphere r2 = -1 (always rejected).
 *
 * The compact summary (prefilter "compact") is each triangle's minimal
 * sphere in 4 bytes, quantised against a frame stored with it, so that the
 * spheres of a leaf of 8 are one cache line against the 4.5 of its vertex
 * rows: a ray that every sphere rejects never fetches the rows.
 *   float o[3], s[3], rs, 0       the frame (32 bytes)
 *   uint8 qx[W], qy[W], qz[W], qr[W]
 * decoded, in this order and without contraction (every kernel and the
 * builder compute the same bits):
 *   c_k = o_k + (float)q_k * s_k,   r = (float)qr * rs,   r2 = r * r.
 * The builder picks qr so that this r2 covers the triangle around this
 * c (the padding rule of sc_sphere_make_conservative_f), and o, s, rs so
 * that no decoded value is subnormal (the same bits with FTZ|DAZ). A leaf
 * it cannot encode gets rs = +inf: r2 = +inf never rejects.
 */
#ifndef SPHERECULL_BVH_LEAF_BLOCK_H
#define SPHERECULL_BVH_LEAF_BLOCK_H

#include <stddef.h>
#include <stdint.h>

#include "node_bvh8.h"

static inline unsigned sc_leaf_width(unsigned count) { return count <= 4 ? 4 : count <= 8 ? 8 : 16; }

/* Bytes of the compact summary: the frame and 4W bytes, padded so the
 * rows after it stay W*4-byte aligned. */
static inline size_t sc_leaf_summary_bytes(unsigned W) { return W == 16 ? 128 : 32 + 4 * (size_t)W; }

/* Bytes in front of the vertex rows for a reference's flags
 * (SC_REF_SPHERES, SC_REF_SUMMARY or 0). */
static inline size_t sc_leaf_head_bytes(unsigned W, uint64_t flags)
{
    return (flags & SC_REF_SPHERES) ? (size_t)W * 16 : (flags & SC_REF_SUMMARY) ? sc_leaf_summary_bytes(W) : 0;
}

/* Bytes of a block: its head, 9W vertex floats, W ids. */
static inline size_t sc_leaf_bytes(unsigned W, uint64_t flags) { return sc_leaf_head_bytes(W, flags) + (size_t)W * 40; }

/* The block a leaf reference points at: its sphere block or summary (when
 * it has one) and its vertex rows. */
static inline const float *sc_leaf_block(const unsigned char *leaves, uint64_t ref)
{
    return (const float *)(const void *)(leaves + sc_ref_offset(ref));
}
static inline const float *sc_leaf_rows(const float *block, unsigned W, uint64_t ref)
{
    return (const float *)(const void *)((const unsigned char *)block + sc_leaf_head_bytes(W, ref));
}

/* The compact summary's spheres as an SoA sphere block (cx, cy, cz, r2
 * rows of W): the specification the SIMD decoders follow bit for bit. */
static inline void sc_leaf_summary_decode(const float *sum, unsigned W, float *blk)
{
    const unsigned char *q = (const unsigned char *)(sum + 8);
    for (unsigned i = 0; i < W; i++) {
        for (unsigned k = 0; k < 3; k++)
            blk[k * W + i] = sum[k] + (float)q[k * W + i] * sum[3 + k];
        const float r = (float)q[3 * W + i] * sum[6];
        blk[3 * W + i] = r * r;
    }
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

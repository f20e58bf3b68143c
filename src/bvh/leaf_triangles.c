/* Leaf encoding: the triangles of a binary leaf gathered into a leaf block
 * (leaf_block.h), with their conservative prefilter spheres when the mode
 * (or, for auto, the per-leaf rule of sc_bvh.h) asks for them. The only
 * step of the build that knows triangles. */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "build_internal.h"
#include "common/sc_rng.h"
#include "spherecull/sc_circumsphere.h"
#include "spherecull/sc_prefilter.h"

/* One ray against a sphere block of width W through the public kernels. */
static uint32_t reject_block(const sc_ray *ray, const float *blk, unsigned W)
{
    if (W == 4)
        return sc_reject4(ray, (const sc_sphere_block4 *)(const void *)blk);
    if (W == 8)
        return sc_reject8(ray, (const sc_sphere_block8 *)(const void *)blk);
    return sc_reject16(ray, (const sc_sphere_block16 *)(const void *)blk);
}

static void leaf_spheres(const bvh_builder *B, const sc_bnode *leaf, sc_sphere_kind kind, unsigned W,
                         float *out /* 4W: cx, cy, cz, r2 */)
{
    for (unsigned i = 0; i < W; i++) {
        out[i] = out[W + i] = out[2 * W + i] = 0;
        out[3 * W + i] = -1;
    }
    for (unsigned i = 0; i < leaf->b; i++) {
        uint32_t t = B->ids[leaf->a + i];
        sc_spheref s;
        sc_prefilter_sphere_f(vtx(B, t, 0), vtx(B, t, 1), vtx(B, t, 2), kind, SC_METHOD_TEXTBOOK, &s);
        out[i] = s.c[0], out[W + i] = s.c[1], out[2 * W + i] = s.c[2], out[3 * W + i] = s.r2;
    }
}

/* The auto rule: fraction of isotropic random lines through the leaf's box
 * that every sphere rejects. */
static double auto_skip_rate(const sc_bnode *leaf, const float *blk, unsigned W, uint64_t seed)
{
    const box3 *b = &leaf->box;
    double c[3], R = 0;
    for (int k = 0; k < 3; k++) {
        c[k] = 0.5 * ((double)b->lo[k] + b->hi[k]);
        double h = 0.5 * ((double)b->hi[k] - b->lo[k]);
        R += h * h;
    }
    R = sqrt(R);
    if (!(R > 0) || !isfinite(R))
        return 0;
    sc_rng rng;
    sc_rng_seed(&rng, seed);
    unsigned valid = (1u << leaf->b) - 1;
    int hits = 0, skips = 0;
    for (int attempt = 0; attempt < 4 * SC_BVH_AUTO_SAMPLES && hits < SC_BVH_AUTO_SAMPLES; attempt++) {
        double z = sc_rng_range(&rng, -1, 1), phi = sc_rng_range(&rng, 0, 6.283185307179586);
        double s = sqrt(1 - z * z);
        double d[3] = { s * cos(phi), s * sin(phi), z };
        double u[3], v[3];
        /* Any two unit vectors orthogonal to d. */
        if (fabs(d[0]) < 0.6) u[0] = 0, u[1] = d[2], u[2] = -d[1];
        else u[0] = -d[2], u[1] = 0, u[2] = d[0];
        double un = sqrt(u[0] * u[0] + u[1] * u[1] + u[2] * u[2]);
        for (int k = 0; k < 3; k++) u[k] /= un;
        v[0] = d[1] * u[2] - d[2] * u[1];
        v[1] = d[2] * u[0] - d[0] * u[2];
        v[2] = d[0] * u[1] - d[1] * u[0];
        double x, y;
        do {
            x = sc_rng_range(&rng, -1, 1);
            y = sc_rng_range(&rng, -1, 1);
        } while (x * x + y * y > 1);
        double o[3];
        for (int k = 0; k < 3; k++)
            o[k] = c[k] + R * (x * u[k] + y * v[k]) - 2 * R * d[k];
        /* Does the line meet the box? (Exact enough in double; this only
         * steers a heuristic.) */
        double t0 = 0, t1 = INFINITY;
        for (int k = 0; k < 3; k++) {
            if (d[k] == 0) {
                if (o[k] < b->lo[k] || o[k] > b->hi[k])
                    t1 = -1;
                continue;
            }
            double ta = (b->lo[k] - o[k]) / d[k], tb = (b->hi[k] - o[k]) / d[k];
            if (ta > tb) { double t = ta; ta = tb; tb = t; }
            t0 = fmax(t0, ta);
            t1 = fmin(t1, tb);
        }
        if (!(t0 <= t1))
            continue;
        hits++;
        sc_ray ray = { { (float)o[0], (float)o[1], (float)o[2] }, 0,
                       { (float)d[0], (float)d[1], (float)d[2] }, INFINITY };
        if ((reject_block(&ray, blk, W) & valid) == valid)
            skips++;
    }
    return hits ? (double)skips / hits : 0;
}

uint64_t sc_leaf_emit(bvh_builder *B, uint32_t bi)
{
    const sc_bnode *leaf = &B->bn[bi];
    unsigned n = leaf->b, W = sc_leaf_width(n);
    sc_prefilter_mode mode = B->cfg->prefilter;
    int spheres = mode != SC_PREFILTER_OFF;
    _Alignas(64) float sph[4 * 16];   /* passed to sc_reject* as a sphere block */
    if (mode == SC_PREFILTER_AUTO) {
        /* Blocks of 4 and 8 never qualify (a sphere block costs more than
         * the triangle block it could skip), so they are not sampled. */
        if (B->dry && W == 16) {
            leaf_spheres(B, leaf, SC_SPHERE_MINIMAL, W, sph);
            double rate = auto_skip_rate(leaf, sph, W, 0x5c0ffee ^ ((uint64_t)bi * 0x9e3779b97f4a7c15ull));
            B->auto_use[bi] = rate >= SC_BVH_AUTO_THRESHOLD16;
        }
        spheres = B->auto_use[bi];
    }
    size_t align = (size_t)W * 4;
    size_t off = (B->leaf_used + align - 1) / align * align;
    size_t bytes = sc_leaf_bytes(W, spheres);
    B->leaf_used = off + bytes;
    B->leaves_emitted++;
    if (spheres) {
        B->leaves_spheres++;
        B->sphere_used += (size_t)W * 16;
    }
    B->sah += (double)box_area(&leaf->box) / B->root_area * leaf_blocks(n);
    if (!B->dry) {
        float *block = (float *)(void *)(B->bvh->leaves + off);
        if (spheres)
            leaf_spheres(B, leaf, mode == SC_PREFILTER_CIRCUM ? SC_SPHERE_CIRCUM : SC_SPHERE_MINIMAL, W, block);
        float *f = (float *)sc_leaf_rows(block, W, spheres);
        uint32_t *prim = (uint32_t *)sc_leaf_prims(f, W);
        for (unsigned i = 0; i < W; i++) {
            uint32_t t = B->ids[leaf->a + (i < n ? i : n - 1)];
            for (int corner = 0; corner < 3; corner++) {
                const float *p = vtx(B, t, corner);
                for (int k = 0; k < 3; k++)
                    f[sc_leaf_at(W, (unsigned)corner, (unsigned)k, i)] = p[k];
            }
            prim[i] = t;
        }
    }
    return sc_ref_leaf(off, n, spheres);
}


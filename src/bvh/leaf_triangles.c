/* Leaf encoding: the triangles of a binary leaf gathered into a leaf block
 * (leaf_block.h), with their conservative prefilter spheres when the mode
 * (or, for auto, the per-leaf rule of sc_bvh.h) asks for them. The only
 * step of the build that knows triangles. */
#include <float.h>
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

/* Flushes a subnormal to zero: frame values must read the same with DAZ. */
static float no_subnormal(float x) { return fabsf(x) < FLT_MIN ? 0.0f : x; }

/* The compact summary of a leaf (leaf_block.h): minimal spheres quantised
 * against the leaf's box. Each sphere is re-padded around its decoded
 * centre, so rounding the centre to 8 bits only grows the radius. Returns 0
 * (and writes the never-rejecting summary) when the leaf cannot be encoded:
 * a non-finite frame or sphere, a subnormal decoded centre. */
static int leaf_summary(const bvh_builder *B, const sc_bnode *leaf, unsigned W, float *sum)
{
    unsigned char *q = (unsigned char *)(sum + 8);
    float r2need[16];
    memset(sum, 0, sc_leaf_summary_bytes(W));
    for (int k = 0; k < 3; k++) {
        const float lo = leaf->box.lo[k], hi = leaf->box.hi[k];
        sum[k] = no_subnormal(lo);
        /* steps of at least 2^-100: q * s is 0 or normal */
        sum[3 + k] = fmaxf((hi - sum[k]) / 255.0f, 0x1p-100f);
        if (!isfinite(sum[k]) || !isfinite(sum[3 + k]))
            goto never;
    }
    double rmax = 0;
    for (unsigned i = 0; i < leaf->b; i++) {
        uint32_t t = B->ids[leaf->a + i];
        const float *V[3] = { vtx(B, t, 0), vtx(B, t, 1), vtx(B, t, 2) };
        sc_spheref s;
        sc_prefilter_sphere_f(V[0], V[1], V[2], SC_SPHERE_MINIMAL, SC_METHOD_TEXTBOOK, &s);
        for (int k = 0; k < 3; k++) {
            double x = isfinite(s.c[k]) ? ((double)s.c[k] - sum[k]) / sum[3 + k] : 0;
            x = nearbyint(x < 0 ? 0 : x > 255 ? 255 : x);
            q[k * W + i] = (unsigned char)x;
            s.c[k] = sum[k] + (float)q[k * W + i] * sum[3 + k];   /* the decoded centre */
            if (!isfinite(s.c[k]) || (s.c[k] != 0 && fabsf(s.c[k]) < FLT_MIN))
                goto never;
        }
        sc_sphere_make_conservative_f(V[0], V[1], V[2], &s);
        if (!isfinite(s.r2))
            goto never;
        r2need[i] = s.r2;
        rmax = fmax(rmax, sqrt((double)s.r2));
    }
    /* 254 steps reach the largest radius (255 is left for rounding up);
     * steps of at least 2^-60: r and r * r are normal */
    sum[6] = fmaxf((float)(rmax / 254 * (1 + 0x1p-20)), 0x1p-60f);
    if (!isfinite(sum[6]))
        goto never;
    for (unsigned i = 0; i < leaf->b; i++) {
        unsigned qr = (unsigned)ceil(sqrt((double)r2need[i]) / sum[6]);
        if (qr < 1)
            qr = 1;
        for (;; qr++) {
            if (qr > 255)
                goto never;
            const float r = (float)qr * sum[6];
            if (r * r >= r2need[i])
                break;
        }
        q[3 * W + i] = (unsigned char)qr;
    }
    return 1;
never:
    memset(sum, 0, sc_leaf_summary_bytes(W));
    sum[6] = INFINITY;
    memset(q, 255, 4 * (size_t)W);
    return 0;
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
    int spheres = mode != SC_PREFILTER_OFF && mode != SC_PREFILTER_COMPACT;
    _Alignas(64) float sph[4 * 16];   /* passed to sc_reject* as a sphere block */
    if (mode == SC_PREFILTER_AUTO) {
        /* Blocks of 4 and 8 never qualify (a sphere block costs more than
         * the triangle block it could skip), so they are not sampled. */
        if (B->dry && W == 16) {
            leaf_spheres(B, leaf, SC_SPHERE_MINIMAL, W, sph);
            /* seeded by the leaf's first slot, which the splits fix, not
             * by the binary node's index, which depends on the layout */
            double rate = auto_skip_rate(leaf, sph, W, 0x5c0ffee ^ ((uint64_t)leaf->a * 0x9e3779b97f4a7c15ull));
            B->auto_use[bi] = rate >= SC_BVH_AUTO_THRESHOLD16;
        }
        spheres = B->auto_use[bi];
    }
    size_t align = (size_t)W * 4;
    size_t off = (B->leaf_used + align - 1) / align * align;
    const uint64_t flags = spheres ? SC_REF_SPHERES : mode == SC_PREFILTER_COMPACT ? SC_REF_SUMMARY : 0;
    size_t bytes = sc_leaf_bytes(W, flags);
    B->leaf_used = off + bytes;
    B->leaves_emitted++;
    if (flags) {
        B->leaves_spheres++;
        B->sphere_used += sc_leaf_head_bytes(W, flags);
    }
    B->sah += (double)box_area(&leaf->box) / B->root_area * leaf_blocks(n);
    if (!B->dry) {
        float *block = (float *)(void *)(B->bvh->leaves + off);
        if (spheres)
            leaf_spheres(B, leaf, mode == SC_PREFILTER_CIRCUM ? SC_SPHERE_CIRCUM : SC_SPHERE_MINIMAL, W, block);
        if (flags & SC_REF_SUMMARY)
            leaf_summary(B, leaf, W, block);
        float *f = (float *)sc_leaf_rows(block, W, flags);
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
    return sc_ref_leaf(off, n, flags);
}


void sc_leaf_refit(const bvh_builder *B, uint64_t ref, box3 *box)
{
    const unsigned n = sc_ref_count(ref), W = sc_leaf_width(n);
    float *block = (float *)(void *)(B->bvh->leaves + sc_ref_offset(ref));
    float *f = (float *)sc_leaf_rows(block, W, ref);
    const uint32_t *prim = sc_leaf_prims(f, W);
    uint32_t ids[SC_BVH_MAX_LEAF];
    memcpy(ids, prim, sizeof(uint32_t) * n);
    /* The spheres' and summary's code reads the leaf as a binary leaf over
     * B->ids; this one is a leaf of its own ids. */
    bvh_builder L = *B;
    L.ids = ids;
    sc_bnode leaf = { .a = 0, .b = n, .leaf = 1 };
    box_empty(&leaf.box);
    for (unsigned i = 0; i < n; i++)
        for (int corner = 0; corner < 3; corner++)
            box_grow_point(&leaf.box, vtx(&L, ids[i], corner));
    if (sc_ref_has_spheres(ref))
        leaf_spheres(&L, &leaf, B->cfg->prefilter == SC_PREFILTER_CIRCUM ? SC_SPHERE_CIRCUM : SC_SPHERE_MINIMAL,
                     W, block);
    if (sc_ref_has_summary(ref))
        leaf_summary(&L, &leaf, W, block);
    for (unsigned i = 0; i < W; i++) {
        uint32_t t = ids[i < n ? i : n - 1];
        for (int corner = 0; corner < 3; corner++) {
            const float *p = vtx(&L, t, corner);
            for (int k = 0; k < 3; k++)
                f[sc_leaf_at(W, (unsigned)corner, (unsigned)k, i)] = p[k];
        }
    }
    *box = leaf.box;
}

/* Binned SAH builder (Wald 2007) for a binary tree, collapsed into the 8-wide
 * layout of bvh_internal.h by repeatedly opening the child with the largest
 * surface area (as Embree's BVH8 builder does).
 *
 * Single-threaded: on the 2-core target a 1M-triangle build takes well under
 * a second (bench/bench_trace.c prints it), less than a frame of tracing, so
 * threads did not pay for their complexity yet.
 */
#define _POSIX_C_SOURCE 200809L
#include <float.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "bvh_internal.h"
#include "common/sc_rng.h"
#include "spherecull/sc_circumsphere.h"

#define MAX_BINS 64
/* Below this depth SAH splits may be arbitrarily unbalanced; from it on the
 * builder splits at the object median, so that at most 31 more levels follow
 * and the binary depth stays below SC_BVH_MAX_DEPTH. */
#define MEDIAN_DEPTH 32

typedef struct box3 { float lo[3], hi[3]; } box3;

typedef struct bnode {
    box3 box;
    uint32_t a, b;           /* inner: left, right; leaf: begin, count */
    int leaf;
} bnode;

typedef struct builder {
    const sc_bvh_config *cfg;
    const float *pos;
    const uint32_t *idx;
    box3 *pbox;              /* per triangle */
    float (*cen)[3];         /* per triangle, box centre */
    uint32_t *ids;
    bnode *bn;
    size_t bn_count;
    uint8_t *bin_of;         /* scratch: bin per triangle of the current range */
    /* collapse */
    int dry;                 /* 1: only measure */
    size_t node_used, leaf_used, sphere_used, leaves_emitted, leaves_spheres;
    uint8_t *auto_use;       /* per binary node: auto decision (leaves only) */
    sc_bvh *bvh;
    int max_depth;
    double sah;
    float root_area;
} builder;

static void box_empty(box3 *b)
{
    for (int k = 0; k < 3; k++) {
        b->lo[k] = INFINITY;
        b->hi[k] = -INFINITY;
    }
}

/* Plain compares rather than fminf/fmaxf: those are library calls at -O2
 * (NaN rules), and boxes of finite triangles hold no NaN. */
static inline void box_grow(box3 *b, const box3 *o)
{
    for (int k = 0; k < 3; k++) {
        b->lo[k] = o->lo[k] < b->lo[k] ? o->lo[k] : b->lo[k];
        b->hi[k] = o->hi[k] > b->hi[k] ? o->hi[k] : b->hi[k];
    }
}

static float box_area(const box3 *b)
{
    float d[3];
    for (int k = 0; k < 3; k++) {
        d[k] = b->hi[k] - b->lo[k];
        if (!(d[k] > 0))
            d[k] = 0;
    }
    return 2 * (d[0] * d[1] + d[1] * d[2] + d[2] * d[0]);
}

static float leaf_blocks(size_t n) { return (float)((n + 3) / 4); }

static const float *vtx(const builder *B, uint32_t tri, int corner)
{
    return B->pos + 3 * (size_t)B->idx[3 * (size_t)tri + corner];
}

/* ---- binary build ------------------------------------------------------- */

static void swap_ids(uint32_t *ids, size_t i, size_t j)
{
    uint32_t t = ids[i];
    ids[i] = ids[j];
    ids[j] = t;
}

/* Quickselect: ids[begin..end) partitioned around the element of rank mid by
 * centroid coordinate on axis (ties broken by id, so the result is
 * deterministic). */
static int cen_less(const builder *B, uint32_t x, uint32_t y, int axis)
{
    float a = B->cen[x][axis], b = B->cen[y][axis];
    return a < b || (a == b && x < y);
}

static void select_median(builder *B, size_t begin, size_t end, size_t mid, int axis)
{
    uint32_t *ids = B->ids;
    while (end - begin > 1) {
        size_t p = begin + (end - begin) / 2;
        swap_ids(ids, p, end - 1);
        uint32_t pivot = ids[end - 1];
        size_t store = begin;
        for (size_t i = begin; i < end - 1; i++)
            if (cen_less(B, ids[i], pivot, axis))
                swap_ids(ids, i, store++);
        swap_ids(ids, store, end - 1);
        if (store == mid)
            return;
        if (mid < store)
            end = store;
        else
            begin = store + 1;
    }
}

static uint32_t new_bnode(builder *B) { return (uint32_t)B->bn_count++; }

static uint32_t build_range(builder *B, size_t begin, size_t end, int depth)
{
    uint32_t me = new_bnode(B);
    bnode *node = &B->bn[me];
    size_t n = end - begin;
    box3 bounds, cb;
    box_empty(&bounds);
    box_empty(&cb);
    for (size_t i = begin; i < end; i++) {
        uint32_t t = B->ids[i];
        box_grow(&bounds, &B->pbox[t]);
        box3 c = { { B->cen[t][0], B->cen[t][1], B->cen[t][2] },
                   { B->cen[t][0], B->cen[t][1], B->cen[t][2] } };
        box_grow(&cb, &c);
    }
    node->box = bounds;
    if (depth + 1 > B->max_depth)
        B->max_depth = depth + 1;

    const size_t N = (size_t)B->cfg->leaf_size;
    const float area = box_area(&bounds);
    if (n <= 1) {
        node->leaf = 1, node->a = (uint32_t)begin, node->b = (uint32_t)n;
        return me;
    }

    /* Best binned split over the three axes. */
    const int nb = B->cfg->sah_bins;
    float best_cost = INFINITY;
    int best_axis = -1, best_bin = 0;
    if (depth < MEDIAN_DEPTH) {
        for (int axis = 0; axis < 3; axis++) {
            float ext = cb.hi[axis] - cb.lo[axis];
            if (!(ext > 0))
                continue;
            float scale = (float)nb * (1 - 0x1p-20f) / ext;
            box3 bb[MAX_BINS];
            size_t cnt[MAX_BINS] = { 0 };
            for (int k = 0; k < nb; k++)
                box_empty(&bb[k]);
            for (size_t i = begin; i < end; i++) {
                uint32_t t = B->ids[i];
                int k = (int)((B->cen[t][axis] - cb.lo[axis]) * scale);
                k = k < 0 ? 0 : k >= nb ? nb - 1 : k;
                cnt[k]++;
                box_grow(&bb[k], &B->pbox[t]);
            }
            float rarea[MAX_BINS];
            size_t rcnt[MAX_BINS];
            box3 acc;
            box_empty(&acc);
            size_t c = 0;
            for (int k = nb - 1; k > 0; k--) {
                box_grow(&acc, &bb[k]);
                c += cnt[k];
                rarea[k] = box_area(&acc);
                rcnt[k] = c;
            }
            box_empty(&acc);
            c = 0;
            for (int k = 0; k < nb - 1; k++) {
                box_grow(&acc, &bb[k]);
                c += cnt[k];
                if (c == 0 || rcnt[k + 1] == 0)
                    continue;
                float cost = box_area(&acc) * leaf_blocks(c) + rarea[k + 1] * leaf_blocks(rcnt[k + 1]);
                if (cost < best_cost) {
                    best_cost = cost;
                    best_axis = axis;
                    best_bin = k;
                }
            }
        }
    }

    float leaf_cost = area * leaf_blocks(n);
    float split_cost = B->cfg->traversal_cost * area + best_cost;
    if (n <= N && (best_axis < 0 || leaf_cost <= split_cost)) {
        node->leaf = 1, node->a = (uint32_t)begin, node->b = (uint32_t)n;
        return me;
    }

    size_t mid;
    if (best_axis >= 0) {
        float ext = cb.hi[best_axis] - cb.lo[best_axis];
        float scale = (float)nb * (1 - 0x1p-20f) / ext;
        size_t i = begin, j = end;
        while (i < j) {
            uint32_t t = B->ids[i];
            int k = (int)((B->cen[t][best_axis] - cb.lo[best_axis]) * scale);
            k = k < 0 ? 0 : k >= nb ? nb - 1 : k;
            if (k <= best_bin)
                i++;
            else
                swap_ids(B->ids, i, --j);
        }
        mid = i;
    } else {
        /* Deep, or all centroids equal: object median on the widest axis. */
        int axis = 0;
        for (int k = 1; k < 3; k++)
            if (cb.hi[k] - cb.lo[k] > cb.hi[axis] - cb.lo[axis])
                axis = k;
        mid = begin + n / 2;
        select_median(B, begin, end, mid, axis);
    }
    if (mid == begin || mid == end)
        mid = begin + n / 2;
    uint32_t l = build_range(B, begin, mid, depth + 1);
    uint32_t r = build_range(B, mid, end, depth + 1);
    node = &B->bn[me];
    node->leaf = 0, node->a = l, node->b = r;
    return me;
}

/* ---- leaves --------------------------------------------------------------- */

static size_t leaf_size_bytes(unsigned W, int spheres)
{
    return (size_t)W * 4 * (spheres ? 14 : 10);
}

static void leaf_spheres(const builder *B, const bnode *leaf, sc_sphere_kind kind, unsigned W,
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

static uint32_t reject_block(const sc_ray *ray, const float *blk, unsigned W)
{
    if (W == 4)
        return sc_reject4(ray, (const sc_sphere_block4 *)(const void *)blk);
    if (W == 8)
        return sc_reject8(ray, (const sc_sphere_block8 *)(const void *)blk);
    return sc_reject16(ray, (const sc_sphere_block16 *)(const void *)blk);
}

/* The auto rule: fraction of isotropic random lines through the leaf's box
 * that every sphere rejects. */
static double auto_skip_rate(const bnode *leaf, const float *blk, unsigned W, uint64_t seed)
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

static uint64_t emit_leaf(builder *B, uint32_t bi)
{
    const bnode *leaf = &B->bn[bi];
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
    size_t bytes = leaf_size_bytes(W, spheres);
    B->leaf_used = off + bytes;
    B->leaves_emitted++;
    if (spheres) {
        B->leaves_spheres++;
        B->sphere_used += (size_t)W * 16;
    }
    B->sah += (double)box_area(&leaf->box) / B->root_area * leaf_blocks(n);
    if (!B->dry) {
        float *f = (float *)(void *)(B->bvh->leaves + off);
        if (spheres) {
            leaf_spheres(B, leaf, mode == SC_PREFILTER_CIRCUM ? SC_SPHERE_CIRCUM : SC_SPHERE_MINIMAL, W, f);
            f += 4 * W;
        }
        uint32_t *prim = (uint32_t *)(void *)(f + 9 * W);
        for (unsigned i = 0; i < W; i++) {
            uint32_t t = B->ids[leaf->a + (i < n ? i : n - 1)];
            for (int corner = 0; corner < 3; corner++) {
                const float *p = vtx(B, t, corner);
                for (int k = 0; k < 3; k++)
                    f[(corner * 3 + k) * W + i] = p[k];
            }
            prim[i] = t;
        }
    }
    return SC_REF_LEAF | (spheres ? SC_REF_SPHERES : 0) | ((uint64_t)(n - 1) << 48) | (uint64_t)off;
}

/* ---- collapse into 8-wide nodes ------------------------------------------ */

static uint64_t emit_node(builder *B, const uint32_t *kids_in, int nk_in, int depth)
{
    uint32_t kids[SC_BVH_N];
    int nk = nk_in;
    memcpy(kids, kids_in, sizeof(uint32_t) * (size_t)nk);
    while (nk < SC_BVH_N) {
        int best = -1;
        float best_area = -1;
        for (int i = 0; i < nk; i++) {
            const bnode *c = &B->bn[kids[i]];
            if (!c->leaf && box_area(&c->box) > best_area) {
                best_area = box_area(&c->box);
                best = i;
            }
        }
        if (best < 0)
            break;
        const bnode *c = &B->bn[kids[best]];
        kids[best] = c->a;
        kids[nk++] = c->b;
    }
    /* Children by decreasing surface area: an any-hit query visits them in
     * slot order, and a larger box is more likely to hold an occluder. */
    for (int i = 1; i < nk; i++) {
        uint32_t k = kids[i];
        float a = box_area(&B->bn[k].box);
        int j = i;
        while (j > 0 && box_area(&B->bn[kids[j - 1]].box) < a) {
            kids[j] = kids[j - 1];
            j--;
        }
        kids[j] = k;
    }
    size_t my = B->node_used++;
    if (depth > B->max_depth)
        B->max_depth = depth;
    box3 all;
    box_empty(&all);
    for (int i = 0; i < nk; i++)
        box_grow(&all, &B->bn[kids[i]].box);
    B->sah += B->cfg->traversal_cost * (double)box_area(&all) / B->root_area;
    uint64_t refs[SC_BVH_N] = { 0 };
    for (int i = 0; i < nk; i++) {
        const bnode *c = &B->bn[kids[i]];
        if (c->leaf) {
            refs[i] = emit_leaf(B, kids[i]);
        } else {
            uint32_t two[2] = { c->a, c->b };
            refs[i] = emit_node(B, two, 2, depth + 1);
        }
    }
    if (!B->dry) {
        sc_bvh_node8 *node = &B->bvh->nodes[my];
        for (int i = 0; i < SC_BVH_N; i++) {
            const box3 *b = i < nk ? &B->bn[kids[i]].box : NULL;
            for (int k = 0; k < 3; k++) {
                node->b[2 * k][i] = b ? b->lo[k] : INFINITY;
                node->b[2 * k + 1][i] = b ? b->hi[k] : -INFINITY;
            }
            node->child[i] = refs[i];
        }
    }
    return (uint64_t)(my * sizeof(sc_bvh_node8));
}

/* ---- API ---------------------------------------------------------------- */

void sc_bvh_config_default(sc_bvh_config *cfg)
{
    if (!cfg)
        return;
    /* Leaf 8 with a node visit costed at two leaf blocks (the SAH then
     * fills leaves): measured with `spherecull bench --trav-cost`, 5-10 %
     * faster shadow rays and 3-8 % faster primary rays than leaf 4 / cost 1
     * on dragon, tree_aspen and bunny, and 54-56 instead of 61-66 B/tri. */
    cfg->leaf_size = 8;
    cfg->prefilter = SC_PREFILTER_OFF;
    cfg->tri_test = SC_TRI_WATERTIGHT;
    cfg->isa = SC_TRACE_ISA_AUTO;
    cfg->sah_bins = 32;
    cfg->traversal_cost = 2.0f;
}

static double now_seconds(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

static void *alloc_aligned(size_t bytes)
{
    size_t n = (bytes + 63) / 64 * 64;
    return aligned_alloc(64, n ? n : 64);
}

sc_status sc_bvh_build(const float *positions, size_t vertex_count, const uint32_t *indices,
                       size_t triangle_count, const sc_bvh_config *cfg_in, sc_bvh **out)
{
    if (!out)
        return SC_ERR_INVALID_ARGUMENT;
    *out = NULL;
    sc_bvh_config cfg;
    if (cfg_in)
        cfg = *cfg_in;
    else
        sc_bvh_config_default(&cfg);
    if (triangle_count && (!positions || !indices))
        return SC_ERR_INVALID_ARGUMENT;
    if (cfg.leaf_size < 1 || cfg.leaf_size > SC_BVH_MAX_LEAF || (unsigned)cfg.prefilter >= SC_PREFILTER_MODE_COUNT ||
        (unsigned)cfg.tri_test >= SC_TRI_TEST_COUNT || (unsigned)cfg.isa >= SC_TRACE_ISA_COUNT ||
        cfg.sah_bins < 4 || cfg.sah_bins > MAX_BINS || !(cfg.traversal_cost >= 0) || !isfinite(cfg.traversal_cost))
        return SC_ERR_INVALID_ARGUMENT;
    if (triangle_count > (size_t)INT32_MAX)
        return SC_ERR_LIMIT;
    for (size_t i = 0; i < 3 * triangle_count; i++)
        if (indices[i] >= vertex_count)
            return SC_ERR_INVALID_ARGUMENT;
    sc_trace_isa isa;
    sc_status st = sc_trace_select(cfg.isa, &isa);
    if (st != SC_OK)
        return st;

    double t0 = now_seconds();
    sc_bvh *bvh = calloc(1, sizeof *bvh);
    builder B = { 0 };
    B.cfg = &cfg;
    B.pos = positions;
    B.idx = indices;
    size_t n = triangle_count;
    B.pbox = malloc(sizeof(box3) * (n ? n : 1));
    B.cen = malloc(sizeof(float[3]) * (n ? n : 1));
    B.ids = malloc(sizeof(uint32_t) * (n ? n : 1));
    B.bn = malloc(sizeof(bnode) * (2 * n + 1));
    B.auto_use = calloc(2 * n + 1, 1);
    st = SC_ERR_OUT_OF_MEMORY;
    if (!bvh || !B.pbox || !B.cen || !B.ids || !B.bn || !B.auto_use)
        goto fail;
    bvh->cfg = cfg;
    bvh->isa = isa;

    size_t used = 0;
    for (size_t t = 0; t < n; t++) {
        box3 b;
        box_empty(&b);
        int finite = 1;
        for (int corner = 0; corner < 3; corner++) {
            const float *p = positions + 3 * (size_t)indices[3 * t + corner];
            for (int k = 0; k < 3; k++) {
                finite &= isfinite(p[k]) != 0;
                b.lo[k] = p[k] < b.lo[k] ? p[k] : b.lo[k];
                b.hi[k] = p[k] > b.hi[k] ? p[k] : b.hi[k];
            }
        }
        if (!finite)
            continue;
        B.pbox[t] = b;
        for (int k = 0; k < 3; k++)
            B.cen[t][k] = 0.5f * b.lo[k] + 0.5f * b.hi[k];
        B.ids[used++] = (uint32_t)t;
    }
    bvh->triangles = used;
    bvh->skipped = n - used;

    size_t root_nodes = 0;
    if (used) {
        uint32_t root = build_range(&B, 0, used, 0);
        B.root_area = box_area(&B.bn[root].box);
        if (!(B.root_area > 0))
            B.root_area = 1;
        for (int k = 0; k < 3; k++) {
            bvh->root_lo[k] = B.bn[root].box.lo[k];
            bvh->root_hi[k] = B.bn[root].box.hi[k];
        }
        /* Pass 1 measures, pass 2 writes with the same traversal order. */
        B.bvh = bvh;
        for (int pass = 0; pass < 2; pass++) {
            B.dry = pass == 0;
            B.node_used = B.leaf_used = B.sphere_used = B.leaves_emitted = B.leaves_spheres = 0;
            B.sah = 0;
            B.max_depth = 0;
            const bnode *r = &B.bn[root];
            uint32_t kids[2] = { r->a, r->b };
            if (r->leaf)
                emit_node(&B, &root, 1, 1);
            else
                emit_node(&B, kids, 2, 1);
            if (pass == 0) {
                bvh->nodes = alloc_aligned(B.node_used * sizeof(sc_bvh_node8));
                bvh->leaves = alloc_aligned(B.leaf_used);
                if (!bvh->nodes || !bvh->leaves)
                    goto fail;
                memset(bvh->leaves, 0, (B.leaf_used + 63) / 64 * 64);
            }
        }
        root_nodes = B.node_used;
        bvh->has_root = 1;
    }
    bvh->node_count = root_nodes;
    bvh->leaf_count = B.leaves_emitted;
    bvh->leaves_with_spheres = B.leaves_spheres;
    bvh->leaf_bytes = B.leaf_used;
    bvh->sphere_bytes = B.sphere_used;
    bvh->depth = B.max_depth;
    bvh->sah_cost = B.sah;
    st = sc_trace_select(isa, &bvh->isa);
    if (st != SC_OK)
        goto fail;
    {
        const sc_trace_kernels *tab = isa == SC_TRACE_ISA_AVX512 ? sc_trace_kernels_avx512
                                      : isa == SC_TRACE_ISA_AVX2 ? sc_trace_kernels_avx2
                                                                 : sc_trace_kernels_scalar;
        bvh->kernels = &tab[cfg.tri_test];
    }
    bvh->build_seconds = now_seconds() - t0;
    free(B.pbox);
    free(B.cen);
    free(B.ids);
    free(B.bn);
    free(B.auto_use);
    *out = bvh;
    return SC_OK;

fail:
    free(B.pbox);
    free(B.cen);
    free(B.ids);
    free(B.bn);
    free(B.auto_use);
    sc_bvh_free(bvh);
    return st;
}

void sc_bvh_free(sc_bvh *bvh)
{
    if (!bvh)
        return;
    free(bvh->nodes);
    free(bvh->leaves);
    free(bvh);
}

sc_status sc_bvh_get_info(const sc_bvh *bvh, sc_bvh_info *info)
{
    if (!bvh || !info)
        return SC_ERR_INVALID_ARGUMENT;
    memset(info, 0, sizeof *info);
    info->triangles = bvh->triangles;
    info->skipped_triangles = bvh->skipped;
    info->nodes = bvh->node_count;
    info->leaves = bvh->leaf_count;
    info->leaves_with_spheres = bvh->leaves_with_spheres;
    info->node_bytes = bvh->node_count * sizeof(sc_bvh_node8);
    info->leaf_bytes = bvh->leaf_bytes;
    info->sphere_bytes = bvh->sphere_bytes;
    info->total_bytes = info->node_bytes + info->leaf_bytes + sizeof *bvh;
    info->depth = bvh->depth;
    info->sah_cost = bvh->sah_cost;
    info->build_seconds = bvh->build_seconds;
    info->isa = bvh->isa;
    info->prefilter = bvh->cfg.prefilter;
    info->leaf_size = bvh->cfg.leaf_size;
    return SC_OK;
}

/* ---- names -------------------------------------------------------------- */

static const char *const mode_names[SC_PREFILTER_MODE_COUNT] = { "off", "circum", "minimal", "auto" };
static const char *const test_names[SC_TRI_TEST_COUNT] = { "watertight", "moller", "exact" };
static const char *const isa_names[SC_TRACE_ISA_COUNT] = { "auto", "scalar", "avx2", "avx512" };

static sc_status lookup(const char *const *names, int count, const char *name, int *out)
{
    if (!name || !out)
        return SC_ERR_INVALID_ARGUMENT;
    for (int i = 0; i < count; i++)
        if (strcmp(names[i], name) == 0) {
            *out = i;
            return SC_OK;
        }
    return SC_ERR_INVALID_ARGUMENT;
}

const char *sc_prefilter_mode_name(sc_prefilter_mode m)
{
    return (unsigned)m < SC_PREFILTER_MODE_COUNT ? mode_names[m] : "unknown";
}
const char *sc_tri_test_name(sc_tri_test t)
{
    return (unsigned)t < SC_TRI_TEST_COUNT ? test_names[t] : "unknown";
}
const char *sc_trace_isa_name(sc_trace_isa i)
{
    return (unsigned)i < SC_TRACE_ISA_COUNT ? isa_names[i] : "unknown";
}

sc_status sc_prefilter_mode_from_name(const char *name, sc_prefilter_mode *out)
{
    int v;
    sc_status s = lookup(mode_names, SC_PREFILTER_MODE_COUNT, name, &v);
    if (s == SC_OK)
        *out = (sc_prefilter_mode)v;
    return s;
}
sc_status sc_tri_test_from_name(const char *name, sc_tri_test *out)
{
    int v;
    sc_status s = lookup(test_names, SC_TRI_TEST_COUNT, name, &v);
    if (s == SC_OK)
        *out = (sc_tri_test)v;
    return s;
}
sc_status sc_trace_isa_from_name(const char *name, sc_trace_isa *out)
{
    int v;
    sc_status s = lookup(isa_names, SC_TRACE_ISA_COUNT, name, &v);
    if (s == SC_OK)
        *out = (sc_trace_isa)v;
    return s;
}

/* The scene handle (sc_accel.h): meshes under one BVH (sc_bvh_build_set),
 * rigid instances under a small top-level tree of 8-wide nodes over their
 * world boxes, traced by the single-ray kernels of each BVH through the
 * public sc_trace_* calls. The top level is scalar: it holds a few
 * thousand boxes at most, and a ray spends its time in the instances'
 * trees. */
#include <float.h>
#include <math.h>
#include <stdatomic.h>
#include <stdlib.h>
#include <string.h>
#if defined(__SSE2__)
#include <emmintrin.h>
#endif

#include "bvh/build_binned_sah.h"
#include "bvh/bvh_internal.h"
#include "common/sc_clock.h"
#include "common/sc_grow.h"
#include "common/sc_mem.h"
#include "spherecull/sc_accel.h"
#include "isa/isa_dispatch.h"
#include "trace/trace_packet.h"
#include "trace/trace_top.h"

typedef struct accel_inst {
    sc_accel *obj;
    float xfm[12];
    double inv[12];              /* world to object: M^-1 and -M^-1 T */
    float cof[9];                /* cof(M) = det(M) M^-T, row-major: normals to world */
    double kappa;                /* ||M||_F ||M^-1||_F >= the condition number */
    double radius;               /* of its world box around T */
} accel_inst;

struct sc_accel {
    atomic_int refs;
    sc_bvh_config cfg;
    sc_mesh_view *views;         /* what the BVH is built from */
    void **copies;               /* per mesh: the SC_ACCEL_COPY arrays, or NULL */
    size_t nmesh, cap_mesh;
    accel_inst *inst;
    size_t ninst, cap_inst;
    sc_bvh *bvh;                 /* over the meshes; NULL when there are none */
    int bvh_stale;               /* meshes attached or moved since the BVH was built */
    size_t bvh_meshes;           /* meshes in the BVH */
    /* The top level (instances only): items 0..ninst-1 are the instances,
     * item ninst the scene's own BVH. */
    size_t top_nodes;            /* 0: no top tree (no instance has a box) */
    sc_top_item *items;          /* ninst + 1 */
    sc_top top;                  /* what the top-level kernels read (trace_top.h) */
    int committed;
    double build_seconds;
    unsigned builds, refits;
};

/* ---- life ------------------------------------------------------------- */

sc_status sc_accel_new(const sc_bvh_config *cfg, sc_accel **out)
{
    if (!out)
        return SC_ERR_INVALID_ARGUMENT;
    *out = NULL;
    sc_accel *a = calloc(1, sizeof *a);
    if (!a)
        return SC_ERR_OUT_OF_MEMORY;
    if (cfg)
        a->cfg = *cfg;
    else
        sc_bvh_config_default(&a->cfg);
    atomic_init(&a->refs, 1);
    *out = a;
    return SC_OK;
}

void sc_accel_retain(sc_accel *a)
{
    if (a)
        atomic_fetch_add_explicit(&a->refs, 1, memory_order_relaxed);
}

void sc_accel_release(sc_accel *a)
{
    if (!a || atomic_fetch_sub_explicit(&a->refs, 1, memory_order_acq_rel) != 1)
        return;
    for (size_t i = 0; i < a->ninst; i++)
        sc_accel_release(a->inst[i].obj);
    for (size_t g = 0; g < a->nmesh; g++)
        free(a->copies[g]);
    free(a->views);
    free(a->copies);
    free(a->inst);
    sc_free_large((void *)a->top.nodes);
    free(a->items);
    sc_bvh_free(a->bvh);
    free(a);
}

/* ---- attach --------------------------------------------------------------- */

sc_status sc_accel_attach_mesh(sc_accel *a, const sc_mesh_view *mesh, unsigned flags, uint32_t *geom_id)
{
    if (!a || !mesh || flags > SC_ACCEL_COPY || !sc_mesh_layout_ok(mesh) || a->nmesh >= UINT32_MAX - 1)
        return SC_ERR_INVALID_ARGUMENT;
    if (mesh->vertex_count > UINT32_MAX || mesh->triangle_count > (size_t)INT32_MAX)
        return SC_ERR_LIMIT;
    if (sc_bvh_check_mesh(mesh) != SC_OK)
        return SC_ERR_INVALID_ARGUMENT;
    if (!sc_grow((void **)&a->views, &a->cap_mesh, a->nmesh + 1, sizeof *a->views))
        return SC_ERR_OUT_OF_MEMORY;
    size_t cap = a->cap_mesh;
    void *copies = realloc(a->copies, cap * sizeof *a->copies);
    if (!copies)
        return SC_ERR_OUT_OF_MEMORY;
    a->copies = copies;
    sc_mesh_view v = *mesh;
    void *copy = NULL;
    if (flags == SC_ACCEL_COPY) {
        size_t nv = mesh->vertex_count, nt = mesh->triangle_count;
        copy = malloc(12 * nv + 12 * nt + 1);
        if (!copy)
            return SC_ERR_OUT_OF_MEMORY;
        float *pos = copy;
        uint32_t *idx = (uint32_t *)(void *)(pos + 3 * nv);
        for (size_t i = 0; i < nv; i++)
            memcpy(pos + 3 * i, sc_mesh_vertex(mesh, i), 12);
        for (size_t t = 0; t < nt; t++)
            memcpy(idx + 3 * t, sc_mesh_triangle(mesh, t), 12);
        v = (sc_mesh_view){ pos, nv, idx, nt, 0, 0 };
    }
    a->views[a->nmesh] = v;
    a->copies[a->nmesh] = copy;
    if (geom_id)
        *geom_id = (uint32_t)a->nmesh;
    a->nmesh++;
    a->bvh_stale = 1;
    a->committed = 0;
    return SC_OK;
}

/* The instance's inverse, normal matrix and condition bound from xfm; 0 if
 * xfm is not finite and invertible. */
static int inst_set(accel_inst *in, const float xfm[12])
{
    double m[3][3], t[3];
    for (int i = 0; i < 3; i++) {
        for (int j = 0; j < 3; j++) {
            m[i][j] = xfm[4 * i + j];
            if (!isfinite(m[i][j]))
                return 0;
        }
        t[i] = xfm[4 * i + 3];
        if (!isfinite(t[i]))
            return 0;
    }
    /* cof(M): its columns are the cross products of M's columns. */
    double c[3][3];
    for (int j = 0; j < 3; j++) {
        int j1 = (j + 1) % 3, j2 = (j + 2) % 3;
        c[0][j] = m[1][j1] * m[2][j2] - m[2][j1] * m[1][j2];
        c[1][j] = m[2][j1] * m[0][j2] - m[0][j1] * m[2][j2];
        c[2][j] = m[0][j1] * m[1][j2] - m[1][j1] * m[0][j2];
    }
    double det = m[0][0] * c[0][0] + m[1][0] * c[1][0] + m[2][0] * c[2][0];
    if (!(fabs(det) > 0) || !isfinite(det))
        return 0;
    double nm = 0, ni = 0;
    for (int i = 0; i < 3; i++) {
        for (int j = 0; j < 3; j++) {
            double v = c[j][i] / det;   /* M^-1 = cof(M)^T / det */
            in->inv[4 * i + j] = v;
            nm += m[i][j] * m[i][j];
            ni += v * v;
            in->cof[3 * i + j] = (float)c[i][j];
            if (!isfinite(v) || !isfinite(in->cof[3 * i + j]))
                return 0;
        }
    }
    for (int i = 0; i < 3; i++)
        in->inv[4 * i + 3] = -(in->inv[4 * i] * t[0] + in->inv[4 * i + 1] * t[1] + in->inv[4 * i + 2] * t[2]);
    in->kappa = sqrt(nm) * sqrt(ni);
    if (!isfinite(in->kappa))
        return 0;
    memcpy(in->xfm, xfm, sizeof in->xfm);
    return 1;
}

sc_status sc_accel_attach_instance(sc_accel *a, sc_accel *obj, const float xfm[12], uint32_t *inst_id)
{
    if (!a || !obj || !xfm || obj == a || !obj->committed || obj->ninst || a->ninst >= UINT32_MAX - 1)
        return SC_ERR_INVALID_ARGUMENT;
    accel_inst in = { 0 };
    if (!inst_set(&in, xfm))
        return SC_ERR_INVALID_ARGUMENT;
    if (!sc_grow((void **)&a->inst, &a->cap_inst, a->ninst + 1, sizeof *a->inst))
        return SC_ERR_OUT_OF_MEMORY;
    in.obj = obj;
    sc_accel_retain(obj);
    a->inst[a->ninst] = in;
    if (inst_id)
        *inst_id = (uint32_t)a->ninst;
    a->ninst++;
    a->committed = 0;
    return SC_OK;
}

sc_status sc_accel_set_transform(sc_accel *a, uint32_t id, const float xfm[12])
{
    if (!a || !xfm || id >= a->ninst)
        return SC_ERR_INVALID_ARGUMENT;
    accel_inst in = a->inst[id];
    if (!inst_set(&in, xfm))
        return SC_ERR_INVALID_ARGUMENT;
    a->inst[id] = in;
    a->committed = 0;
    return SC_OK;
}

sc_status sc_accel_update_vertices(sc_accel *a, uint32_t geom, const float *positions, size_t stride)
{
    if (!a || !positions || geom >= a->nmesh)
        return SC_ERR_INVALID_ARGUMENT;
    sc_mesh_view v = a->views[geom];
    v.positions = positions;
    v.vertex_stride = stride;
    if (!sc_mesh_layout_ok(&v))
        return SC_ERR_INVALID_ARGUMENT;
    if (a->copies[geom]) {
        float *dst = a->copies[geom];
        for (size_t i = 0; i < v.vertex_count; i++)
            memcpy(dst + 3 * i, sc_mesh_vertex(&v, i), 12);
    } else {
        a->views[geom] = v;
    }
    a->bvh_stale = 1;
    a->committed = 0;
    return SC_OK;
}

/* ---- commit ------------------------------------------------------------- */

/* The box (lo, hi) mapped by an instance, in double, grown into [l, h]:
 * the image of centre c and half-extent e is M c + T +- |M| e. */
static void grow_mapped(const accel_inst *in, const float lo[3], const float hi[3], double l[3], double h[3])
{
    const double c[3] = { 0.5 * ((double)lo[0] + hi[0]), 0.5 * ((double)lo[1] + hi[1]), 0.5 * ((double)lo[2] + hi[2]) };
    const double e[3] = { 0.5 * ((double)hi[0] - lo[0]), 0.5 * ((double)hi[1] - lo[1]), 0.5 * ((double)hi[2] - lo[2]) };
    for (int i = 0; i < 3; i++) {
        const float *r = in->xfm + 4 * i;
        const double w = (double)r[0] * c[0] + (double)r[1] * c[1] + (double)r[2] * c[2] + r[3];
        const double x = fabs((double)r[0]) * e[0] + fabs((double)r[1]) * e[1] + fabs((double)r[2]) * e[2];
        l[i] = fmin(l[i], w - x);
        h[i] = fmax(h[i], w + x);
    }
}

/* The boxes of the object's tree down to `levels` below node, mapped. */
static void grow_node(const accel_inst *in, const sc_bvh *b, const sc_bvh_node8 *node, int levels, double l[3],
                      double h[3])
{
    for (int i = 0; i < SC_BVH_N; i++) {
        const uint64_t c = node->child[i];
        if (!c)
            continue;
        if (levels > 0 && !sc_ref_is_leaf(c)) {
            grow_node(in, b, (const sc_bvh_node8 *)(const void *)((const unsigned char *)b->nodes + sc_ref_offset(c)),
                      levels - 1, l, h);
            continue;
        }
        const float lo[3] = { node->b[0][i], node->b[2][i], node->b[4][i] },
                    hi[3] = { node->b[1][i], node->b[3][i], node->b[5][i] };
        grow_mapped(in, lo, hi, l, h);
    }
}

/* The world box of an instance: the boxes of the object tree's top two
 * levels (up to 64) mapped in double, rather than its root box alone: a
 * rotated object's box of its box can be far larger than the object, and
 * every ray through the difference pays an instance visit for nothing.
 * Rounded outward, padded by 2^-20 of its extent. */
static void world_box(const accel_inst *in, const sc_bvh *b, box3 *out)
{
    double l[3] = { INFINITY, INFINITY, INFINITY }, h[3] = { -INFINITY, -INFINITY, -INFINITY };
    grow_node(in, b, &b->nodes[0], 1, l, h);
    for (int i = 0; i < 3; i++) {
        double pad = (h[i] - l[i]) * 0x1p-20 + (fabs(l[i]) + fabs(h[i])) * 0x1p-40;
        out->lo[i] = nextafterf((float)(l[i] - pad), -INFINITY);
        out->hi[i] = nextafterf((float)(h[i] + pad), INFINITY);
    }
}

typedef struct top_builder {
    const sc_bnode *bn;
    const uint32_t *ids;
    sc_bvh_node8 *nodes;
    size_t used;
} top_builder;

/* The binary tree collapsed into 8-wide nodes as the BVH's collapse does
 * (open the largest child); a leaf reference carries its item in the
 * offset bits. */
static uint64_t top_collapse(top_builder *T, const uint32_t *kids_in, int nk)
{
    uint32_t kids[SC_BVH_N];
    memcpy(kids, kids_in, sizeof(uint32_t) * (size_t)nk);
    while (nk < SC_BVH_N) {
        int best = -1;
        float best_area = -1;
        for (int i = 0; i < nk; i++) {
            const sc_bnode *c = &T->bn[kids[i]];
            if (!c->leaf && box_area(&c->box) > best_area)
                best_area = box_area(&c->box), best = i;
        }
        if (best < 0)
            break;
        const sc_bnode *c = &T->bn[kids[best]];
        kids[best] = c->a;
        kids[nk++] = c->b;
    }
    size_t my = T->used++;
    sc_bvh_node8 *node = &T->nodes[my];
    for (int i = 0; i < SC_BVH_N; i++) {
        const sc_bnode *c = i < nk ? &T->bn[kids[i]] : NULL;
        for (int k = 0; k < 3; k++) {
            node->b[2 * k][i] = c ? c->box.lo[k] : INFINITY;
            node->b[2 * k + 1][i] = c ? c->box.hi[k] : -INFINITY;
        }
        uint64_t ref = 0;
        if (c && c->leaf) {
            ref = SC_REF_LEAF | T->ids[c->a];
        } else if (c) {
            uint32_t two[2] = { c->a, c->b };
            ref = (uint64_t)top_collapse(T, two, 2);
        }
        node->child[i] = ref;
    }
    return my;
}

static sc_status build_top(sc_accel *a)
{
    sc_free_large((void *)a->top.nodes);
    free(a->items);
    a->items = NULL;
    a->top_nodes = 0;
    memset(&a->top, 0, sizeof a->top);
    if (!a->ninst)
        return SC_OK;
    const size_t nitems = a->ninst + 1;
    box3 *boxes = malloc(nitems * sizeof *boxes);
    uint32_t *ids = malloc(nitems * sizeof *ids);
    sc_bnode *bn = malloc((2 * nitems + 1) * sizeof *bn);
    sc_bvh_node8 *nodes = sc_alloc_large((nitems + 1) * sizeof(sc_bvh_node8));
    a->items = malloc(nitems * sizeof *a->items);
    sc_status st = SC_ERR_OUT_OF_MEMORY;
    if (!boxes || !ids || !bn || !nodes || !a->items) {
        free(nodes);
        goto out;
    }
    a->top.nodes = nodes;
    a->top.items = a->items;
    a->top.item_count = (uint32_t)nitems;
    a->top.kappa = 1;
    a->top.radius = 0;
    size_t n = 0;
    box3 all;
    box_empty(&all);
    for (size_t i = 0; i < nitems; i++) {
        /* The item reads its BVH through the scene that owns it, at trace
         * time: a scene committed again behind an instance is at worst
         * culled by stale boxes, never freed memory. */
        const sc_bvh *const *slot = (const sc_bvh *const *)(i < a->ninst ? &a->inst[i].obj->bvh : &a->bvh);
        a->items[i] = (sc_top_item){ slot, i < a->ninst ? a->inst[i].inv : NULL,
                                     i < a->ninst ? a->inst[i].cof : NULL,
                                     i < a->ninst ? (uint32_t)i : SC_INVALID_ID, -1, INFINITY, -1,
                                     { 0, 0, 0 }, 0 };
        if (i < a->ninst)
            sc_top_valid_bounds(a->inst[i].inv, a->inst[i].xfm, &a->items[i].vo, &a->items[i].vdlo,
                                &a->items[i].vdhi);
        const sc_bvh *b = *slot;
        if (!b || !b->has_root)
            continue;
        if (i < a->ninst) {
            accel_inst *in = &a->inst[i];
            world_box(in, b, &boxes[n]);
            double r = 0;
            for (int k = 0; k < 3; k++) {
                double e = fmax(fabs((double)boxes[n].lo[k] - in->xfm[4 * k + 3]),
                                fabs((double)boxes[n].hi[k] - in->xfm[4 * k + 3]));
                r += e * e;
            }
            a->top.kappa = fmax(a->top.kappa, in->kappa);
            a->top.radius = fmax(a->top.radius, sqrt(r));
        } else {
            for (int k = 0; k < 3; k++)
                boxes[n].lo[k] = b->root_lo[k], boxes[n].hi[k] = b->root_hi[k];
        }
        double h2 = 0;
        for (int k = 0; k < 3; k++) {
            const double e = 0.5 * ((double)boxes[n].hi[k] - boxes[n].lo[k]);
            a->items[i].center[k] = (float)(0.5 * ((double)boxes[n].lo[k] + boxes[n].hi[k]));
            h2 += e * e;
        }
        a->items[i].half = (float)sqrt(h2);
        box_grow(&all, &boxes[n]);
        ids[n++] = (uint32_t)i;
    }
    st = SC_OK;
    if (!n)
        goto out;
    double h2 = 0;
    for (int k = 0; k < 3; k++) {
        a->top.lo[k] = all.lo[k], a->top.hi[k] = all.hi[k];
        a->top.center[k] = (float)(0.5 * ((double)all.lo[k] + all.hi[k]));
        h2 += 0.25 * ((double)all.hi[k] - all.lo[k]) * ((double)all.hi[k] - all.lo[k]);
    }
    a->top.half = (float)sqrt(h2);
    sc_top_growth_consts(&a->top);
    const sc_sah_params sah = { 1, 16, 1.0f, 1 };
    size_t count;
    uint32_t root = sc_build_binned_sah(boxes, ids, n, &sah, bn, &count);
    top_builder T = { bn, ids, nodes, 0 };
    if (bn[root].leaf)
        top_collapse(&T, &root, 1);
    else
        top_collapse(&T, (uint32_t[2]){ bn[root].a, bn[root].b }, 2);
    a->top_nodes = T.used;
out:
    free(boxes);
    free(ids);
    free(bn);
    return st;
}

static sc_status build_meshes(sc_accel *a)
{
    sc_bvh_free(a->bvh);
    a->bvh = NULL;
    a->bvh_meshes = 0;
    if (!a->nmesh)
        return SC_OK;
    sc_status st = sc_bvh_build_set(a->views, a->nmesh, &a->cfg, &a->bvh);
    if (st != SC_OK)
        return st;
    a->bvh_meshes = a->nmesh;
    a->bvh_stale = 0;
    a->builds++;
    return SC_OK;
}

/* Every instanced scene still committed (its tree is what the top level's
 * boxes are built from). */
static int objects_committed(const sc_accel *a)
{
    for (size_t i = 0; i < a->ninst; i++)
        if (!a->inst[i].obj->committed)
            return 0;
    return 1;
}

/* The end of a commit or refit: the top level, then committed. */
static sc_status finish(sc_accel *a, sc_status st, double t0)
{
    if (st == SC_OK)
        st = build_top(a);
    if (st != SC_OK)
        return st;
    a->committed = 1;
    a->build_seconds = sc_now_seconds() - t0;
    return SC_OK;
}

sc_status sc_accel_commit(sc_accel *a)
{
    if (!a)
        return SC_ERR_INVALID_ARGUMENT;
    if (!objects_committed(a))
        return SC_ERR_INVALID_ARGUMENT;
    double t0 = sc_now_seconds();
    a->committed = 0;
    /* Meshes attached or updated since the last build are built afresh
     * (only sc_accel_refit refits); the top level always is. */
    sc_status st = SC_OK;
    if (a->bvh_stale || a->bvh_meshes != a->nmesh)
        st = build_meshes(a);
    return finish(a, st, t0);
}

sc_status sc_accel_refit(sc_accel *a)
{
    if (!a)
        return SC_ERR_INVALID_ARGUMENT;
    if (!a->bvh || a->bvh_meshes != a->nmesh)
        return sc_accel_commit(a);
    if (!objects_committed(a))
        return SC_ERR_INVALID_ARGUMENT;
    double t0 = sc_now_seconds();
    a->committed = 0;
    sc_status st = sc_bvh_refit_set(a->bvh, a->views, a->nmesh);
    if (st == SC_OK && a->bvh->sah_cost > SC_ACCEL_REBUILD_GROWTH * a->bvh->built_sah_cost)
        st = SC_ERR_LIMIT;   /* drifted too far: build afresh */
    if (st == SC_OK)
        a->refits++;
    else if (st == SC_ERR_NONFINITE || st == SC_ERR_LIMIT)
        st = build_meshes(a);
    return finish(a, st, t0);
}

/* ---- trace -------------------------------------------------------------- */

sc_status sc_accel_instance_ray(const sc_accel *a, uint32_t id, const sc_ray *ray, sc_ray *out)
{
    if (!a || !ray || !out || id >= a->ninst || !sc_ray_valid(ray))
        return SC_ERR_INVALID_ARGUMENT;
    sc_top_object_ray(a->inst[id].inv, ray, out);
    return SC_OK;
}

sc_status sc_accel_closest(const sc_accel *a, const sc_ray *ray, sc_hitrec *hit, sc_trace_stats *st)
{
    if (!a || !ray || !hit || !a->committed || !sc_ray_valid_sse(ray))
        return SC_ERR_INVALID_ARGUMENT;
    if (!a->ninst) {
        if (!a->bvh) {
            sc_top_miss(ray->tmax, hit);
            if (st)
                st->rays++;
            return SC_OK;
        }
        sc_status s = sc_trace_closest(a->bvh, ray, hit, st);
        sc_top_map_ids(a->bvh, hit);
        return s;
    }
    sc_top_miss(ray->tmax, hit);
    if (a->top_nodes)
        sc_kernels_active()->trace[0].top_closest(&a->top, ray, hit, st);
    if (st)
        st->rays++;
    return SC_OK;
}

sc_status sc_accel_any(const sc_accel *a, const sc_ray *ray, int *occluded, sc_trace_stats *st)
{
    if (!a || !ray || !occluded || !a->committed || !sc_ray_valid_sse(ray))
        return SC_ERR_INVALID_ARGUMENT;
    if (!a->ninst) {
        if (!a->bvh) {
            *occluded = 0;
            if (st)
                st->rays++;
            return SC_OK;
        }
        return sc_trace_any(a->bvh, ray, occluded, st);
    }
    *occluded = a->top_nodes ? sc_kernels_active()->trace[0].top_any(&a->top, ray, st) : 0;
    if (st)
        st->rays++;
    return SC_OK;
}

/* ---- packets and streams ------------------------------------------------ */

/* Lanes `lanes` (checked rays) of a committed scene's W-lane packet (rows
 * and out as sc_trace_packet_lanes). */
static void accel_packet_lanes(const sc_accel *a, uint32_t lanes, const float *rows, unsigned W, void *out, int any,
                               sc_trace_stats *st)
{
    if (!lanes)
        return;   /* nothing to trace, nothing read or written */
    if (!a->ninst && a->bvh) {
        /* one tree: the packet kernels, ids mapped to (geom, prim) */
        sc_trace_packet_lanes(a->bvh, lanes, rows, W, out, any, st);
        if (!any && a->bvh->mesh_count > 1)
            for (uint32_t e = lanes; e; e &= e - 1) {
                const unsigned i = (unsigned)__builtin_ctz(e);
                sc_hitrec h;
                sc_hit_lane_get(out, W, i, &h);
                sc_top_map_ids(a->bvh, &h);
                sc_hit_lane_put(out, W, i, &h);
            }
        return;
    }
    if (a->ninst && a->top_nodes) {
        sc_kernels_active()->trace[0].top_packet(&a->top, lanes, rows, W, out, any, st);
    } else {
        /* nothing to hit */
        for (uint32_t e = lanes; e; e &= e - 1) {
            const unsigned i = (unsigned)__builtin_ctz(e);
            if (any) {
                ((int32_t *)out)[i] = 0;
            } else {
                sc_hitrec h;
                sc_top_miss(rows[7 * W + i], &h);
                sc_hit_lane_put(out, W, i, &h);
            }
        }
    }
    if (st)
        st->rays += (uint64_t)__builtin_popcount(lanes);
}

/* One body for the four packet calls. */
static sc_status accel_packet(const sc_accel *a, const int32_t *valid, const float *rows, unsigned W, void *out,
                              int any, sc_trace_stats *st)
{
    const int64_t lanes = a && a->committed ? sc_packet_checked_lanes(valid, rows, W, out, any) : -1;
    if (lanes < 0)
        return SC_ERR_INVALID_ARGUMENT;
    accel_packet_lanes(a, (uint32_t)lanes, rows, W, out, any, st);
    return SC_OK;
}

sc_status sc_accel_closest8(const sc_accel *a, const int32_t valid[8], const sc_ray_packet8 *rays,
                            sc_hit_packet8 *hits, sc_trace_stats *st)
{
    return accel_packet(a, valid, (const float *)(const void *)rays, 8, hits, 0, st);
}

sc_status sc_accel_closest16(const sc_accel *a, const int32_t valid[16], const sc_ray_packet16 *rays,
                             sc_hit_packet16 *hits, sc_trace_stats *st)
{
    return accel_packet(a, valid, (const float *)(const void *)rays, 16, hits, 0, st);
}

sc_status sc_accel_any8(const sc_accel *a, const int32_t valid[8], const sc_ray_packet8 *rays, int32_t occluded[8],
                        sc_trace_stats *st)
{
    return accel_packet(a, valid, (const float *)(const void *)rays, 8, occluded, 1, st);
}

sc_status sc_accel_any16(const sc_accel *a, const int32_t valid[16], const sc_ray_packet16 *rays,
                         int32_t occluded[16], sc_trace_stats *st)
{
    return accel_packet(a, valid, (const float *)(const void *)rays, 16, occluded, 1, st);
}

/* A scene as a stream's target (sc_stream_run). */
static void accel_packet16(const void *obj, uint32_t lanes, const sc_ray_packet16 *rays, void *out, int any,
                           sc_trace_stats *st)
{
    accel_packet_lanes(obj, lanes, rays->ox, 16, out, any, st);
}

static sc_status accel_single(const void *obj, const sc_ray *ray, void *out, int any, int incoherent,
                              sc_trace_stats *st)
{
    (void)incoherent;
    if (!any)
        return sc_accel_closest(obj, ray, out, st);
    int o = 0;
    const sc_status s = sc_accel_any(obj, ray, &o, st);
    if (s == SC_OK)
        *(int32_t *)out = o;
    return s;
}

/* accel_single's choices for a run of rays (the top level: a stream of an
 * instanced scene), with the kernels looked up once. */
static sc_status accel_alone(const void *obj, const char *rays, size_t ray_stride, char *out, size_t out_stride,
                             unsigned cnt, int any)
{
    const sc_accel *a = obj;
    const sc_trace_kernels *k = &sc_kernels_active()->trace[0];
    sc_status status = SC_OK;
    for (unsigned i = 0; i < cnt; i++) {
        const sc_ray *r = (const sc_ray *)(const void *)(rays + i * ray_stride);
        void *o = out + i * out_stride;
        if (!sc_ray_valid_sse(r)) {
            status = SC_ERR_INVALID_ARGUMENT;
        } else if (any) {
            *(int32_t *)o = a->top_nodes ? k->top_any(&a->top, r, NULL) : 0;
        } else {
            sc_top_miss(r->tmax, o);
            if (a->top_nodes)
                k->top_closest(&a->top, r, o, NULL);
        }
    }
    return status;
}

/* The streams' arguments: out is the result array, out_min its element size. */
static int stream_ok(const sc_accel *a, const sc_ray *rays, size_t ray_stride, const void *out, size_t out_stride,
                     size_t out_min, size_t n, unsigned flags)
{
    return a && (!n || (rays && out)) && ray_stride >= sizeof(sc_ray) && out_stride >= out_min && !flags &&
           a->committed;
}

/* An instanced scene streams through the top level: coherent runs of 16 as
 * packets (sc_accel_closest16), the rest ray by ray. */
static sc_status accel_stream(const sc_accel *a, const sc_ray *rays, size_t ray_stride, void *out, size_t out_stride,
                              size_t n, sc_trace_stats *st, int any)
{
    const sc_stream_target T = { a, a->top.lo, a->top.hi, accel_packet16, accel_single, accel_alone, NULL, NULL };
    return sc_stream_run(&T, rays, ray_stride, out, out_stride, n, st, any);
}

sc_status sc_accel_closest_n(const sc_accel *a, const sc_ray *rays, size_t ray_stride, sc_hitrec *hits,
                             size_t hit_stride, size_t n, unsigned flags, sc_trace_stats *st)
{
    if (!stream_ok(a, rays, ray_stride, hits, hit_stride, sizeof(sc_hitrec), n, flags))
        return SC_ERR_INVALID_ARGUMENT;
    if (!a->ninst && a->bvh) {
        sc_status s = sc_trace_closest_n(a->bvh, rays, ray_stride, hits, hit_stride, n, flags, st);
        /* not the records of refused rays, which the stream left as they were */
        if (a->bvh->mesh_count > 1)
            for (size_t i = 0; i < n; i++)
                if (s == SC_OK || sc_ray_valid_sse((const sc_ray *)(const void *)((const char *)rays + i * ray_stride)))
                    sc_top_map_ids(a->bvh, (sc_hitrec *)(void *)((char *)hits + i * hit_stride));
        return s;
    }
    return accel_stream(a, rays, ray_stride, hits, hit_stride, n, st, 0);
}

sc_status sc_accel_any_n(const sc_accel *a, const sc_ray *rays, size_t ray_stride, int32_t *occluded,
                         size_t occluded_stride, size_t n, unsigned flags, sc_trace_stats *st)
{
    if (!stream_ok(a, rays, ray_stride, occluded, occluded_stride, sizeof(int32_t), n, flags))
        return SC_ERR_INVALID_ARGUMENT;
    if (!a->ninst && a->bvh)
        return sc_trace_any_n(a->bvh, rays, ray_stride, occluded, occluded_stride, n, flags, st);
    return accel_stream(a, rays, ray_stride, occluded, occluded_stride, n, st, 1);
}

sc_status sc_accel_get_info(const sc_accel *a, sc_accel_info *info)
{
    if (!a || !info)
        return SC_ERR_INVALID_ARGUMENT;
    memset(info, 0, sizeof *info);
    info->meshes = a->nmesh;
    info->instances = a->ninst;
    for (size_t g = 0; g < a->nmesh; g++) {
        info->triangles += a->views[g].triangle_count;
        if (a->copies[g])
            info->bytes += 12 * (a->views[g].vertex_count + a->views[g].triangle_count);
    }
    for (size_t i = 0; i < a->ninst; i++)
        for (size_t g = 0; g < a->inst[i].obj->nmesh; g++)
            info->instanced_triangles += a->inst[i].obj->views[g].triangle_count;
    info->bytes += sizeof *a + a->cap_mesh * (sizeof *a->views + sizeof *a->copies) +
                   a->cap_inst * sizeof *a->inst + a->top_nodes * sizeof(sc_bvh_node8) +
                   (a->ninst ? (a->ninst + 1) * sizeof(sc_top_item) : 0);
    if (a->bvh) {
        sc_bvh_info bi;
        sc_bvh_get_info(a->bvh, &bi);
        info->bytes += bi.total_bytes;
        info->sah_growth = bi.built_sah_cost > 0 ? bi.sah_cost / bi.built_sah_cost : 1;
    } else {
        info->sah_growth = 1;
    }
    info->build_seconds = a->build_seconds;
    info->builds = a->builds;
    info->refits = a->refits;
    info->committed = a->committed;
    return SC_OK;
}

/* The top level of a two-level scene for packets (trace_packet.h): built
 * at the baseline ISA, since a packet spends its time in the instances'
 * trees, where sc_trace_packet_lanes runs the active level's kernels.
 *
 * A packet pays where its rays stay together through a tree, that is where
 * the packet is narrow next to what it is tracing. Its width at distance D
 * from its first origin is about ospread + dspread D (the spread of its
 * origins, and of its directions scaled to unit L1 length); against an
 * item of half diagonal h (its world box) the packet goes on as one packet
 * of object rays only while that width is at most SC_TOP_PACKET_SPREAD h,
 * and lane by lane through the single-ray kernels otherwise; against the
 * whole scene the same test decides whether the packet walks the top tree
 * at all, or each lane goes through the single-ray top kernel. A camera
 * tile seen against 8 large instances of a 100k-triangle mesh passes; the
 * same tile against 1,000 small ones (each a few tiles on screen) fails at
 * the instances, where the packet kernel ran at 0.85x the single rays; a
 * tile's diffuse bounces fail at the root (docs/scenes.md). The answers
 * are the same either way. */
#include <math.h>
#include <string.h>

#include "isa/isa_dispatch.h"
#include "trace_packet.h"
#include "trace_top.h"
#include "traverse_stack.h"

#define SC_TOP_PACKET_SPREAD 0.1f

typedef struct top_packet {
    const sc_top *T;
    unsigned W;
    sc_ray ray[16];
    sc_top_ray tr[16];
    sc_hitrec best[16];          /* closest */
    float tcull[16];             /* sc_top_tmax of each lane: how far its boxes are tested */
    int32_t *occluded;           /* any */
    uint32_t active;             /* lanes still looking (any: not yet occluded) */
    float o0[3], ospread, dspread;
    int any;
    sc_trace_stats *st;
} top_packet;

typedef struct top_entry {
    uint64_t ref;
    uint32_t lanes;
} top_entry;

/* Whether the packet is narrow next to a box of centre c and half
 * diagonal h (see the top of the file). */
static int top_packet_narrow(const top_packet *P, const float c[3], float h)
{
    float D = 0;
    for (int k = 0; k < 3; k++) {
        const float dk = fabsf(c[k] - P->o0[k]);
        D = dk > D ? dk : D;
    }
    return P->ospread + P->dspread * D <= SC_TOP_PACKET_SPREAD * h;
}

/* A hit h of item it for lane l: kept if it beats the lane's best. */
static void top_packet_offer(top_packet *P, const sc_top_item *it, const sc_bvh *b, unsigned l, sc_hitrec *h)
{
    sc_top_map_ids(b, h);
    if (h->prim != SC_HITREC_MISS)
        h->inst = it->inst;
    if (sc_top_better(h, &P->best[l])) {
        if (it->inv)
            sc_top_normal(it->cof, h->ng);
        P->best[l] = *h;
        P->tcull[l] = sc_top_tmax(h, P->ray[l].tmax);
    }
}

static void top_packet_occluded(top_packet *P, unsigned l)
{
    P->occluded[l] = 1;
    P->active &= ~(1u << l);
}

/* The lanes L that reached item `item`: their object rays as one packet,
 * or one by one where the packet is wide next to the item. */
static void top_packet_visit(top_packet *P, uint32_t item, uint32_t L)
{
    const sc_top_item *it = &P->T->items[item];
    const sc_bvh *b = *it->bvh;
    if (!b)
        return;
    const unsigned W = P->W;
    _Alignas(64) float rows[8 * 16];
    uint32_t ok = 0;
    for (uint32_t e = L; e; e &= e - 1) {
        const unsigned l = (unsigned)__builtin_ctz(e);
        sc_ray r = P->ray[l];
        if (it->inv) {
            sc_top_object_ray(it->inv, &P->ray[l], &r);
            if (!sc_ray_valid(&r))
                continue;
        }
        if (!P->any)
            r.tmax = sc_top_item_tmax(b, &P->best[l], P->ray[l].tmax);
        const float f[8] = { r.org[0], r.org[1], r.org[2], r.tmin, r.dir[0], r.dir[1], r.dir[2], r.tmax };
        for (unsigned k = 0; k < 8; k++)
            rows[k * W + l] = f[k];
        ok |= 1u << l;
    }
    if (!ok)
        return;
    sc_trace_stats s;
    memset(&s, 0, sizeof s);
    sc_trace_stats *sp = P->st ? &s : NULL;
    if (!top_packet_narrow(P, it->center, it->half)) {
        const sc_trace_kernels *k = &sc_kernels_active()->trace[b->cfg.tri_test];
        for (uint32_t e = ok; e; e &= e - 1) {
            const unsigned l = (unsigned)__builtin_ctz(e);
            const sc_ray r = { { rows[l], rows[W + l], rows[2 * W + l] }, rows[3 * W + l],
                               { rows[4 * W + l], rows[5 * W + l], rows[6 * W + l] }, rows[7 * W + l] };
            if (P->any) {
                if (sp ? k->any_stats(b, &r, sp) : k->any(b, &r))
                    top_packet_occluded(P, l);
            } else {
                sc_hitrec h;
                if (sp)
                    k->closest_stats(b, &r, &h, sp);
                else
                    k->closest(b, &r, &h);
                top_packet_offer(P, it, b, l, &h);
            }
        }
    } else {
        /* the kernels load whole rows: the other lanes repeat a traced one */
        const unsigned f = (unsigned)__builtin_ctz(ok);
        for (unsigned l = 0; l < W; l++)
            if (!(ok >> l & 1))
                for (unsigned k = 0; k < 8; k++)
                    rows[k * W + l] = rows[k * W + f];
        if (P->any) {
            int32_t occ[16];
            sc_trace_packet_lanes(b, ok, rows, W, occ, 1, sp);
            for (uint32_t e = ok; e; e &= e - 1) {
                const unsigned l = (unsigned)__builtin_ctz(e);
                if (occ[l])
                    top_packet_occluded(P, l);
            }
        } else {
            sc_hit_packet16 hp;
            sc_trace_packet_lanes(b, ok, rows, W, &hp, 0, sp);
            for (uint32_t e = ok; e; e &= e - 1) {
                const unsigned l = (unsigned)__builtin_ctz(e);
                sc_hitrec h;
                sc_hit_lane_get(&hp, W, l, &h);
                top_packet_offer(P, it, b, l, &h);
            }
        }
    }
    /* the objects' counters, but not their rays: the caller counts each ray once */
    if (P->st)
        P->st->nodes += s.nodes, P->st->leaves += s.leaves, P->st->sphere_tests += s.sphere_tests,
            P->st->sphere_rejects += s.sphere_rejects, P->st->tri_tests += s.tri_tests, P->st->tri_hits += s.tri_hits;
}

/* The packet's first origin and its spreads (see the top of the file). */
static void top_packet_spread(top_packet *P, uint32_t lanes)
{
    float ulo[3], uhi[3], olo[3], ohi[3];
    const unsigned f0 = (unsigned)__builtin_ctz(lanes);
    for (int k = 0; k < 3; k++)
        ulo[k] = olo[k] = INFINITY, uhi[k] = ohi[k] = -INFINITY, P->o0[k] = P->ray[f0].org[k];
    for (uint32_t e = lanes; e; e &= e - 1) {
        const sc_ray *r = &P->ray[__builtin_ctz(e)];
        const float inv = 1 / (fabsf(r->dir[0]) + fabsf(r->dir[1]) + fabsf(r->dir[2]));
        for (int k = 0; k < 3; k++) {
            /* compares, not fminf/fmaxf: those are calls at this ISA level */
            const float u = r->dir[k] * inv, o = r->org[k];
            ulo[k] = u < ulo[k] ? u : ulo[k], uhi[k] = u > uhi[k] ? u : uhi[k];
            olo[k] = o < olo[k] ? o : olo[k], ohi[k] = o > ohi[k] ? o : ohi[k];
        }
    }
    P->ospread = P->dspread = 0;
    for (int k = 0; k < 3; k++) {
        const float os = ohi[k] - olo[k], ds = uhi[k] - ulo[k];
        P->ospread = os > P->ospread ? os : P->ospread;
        P->dspread = ds > P->dspread ? ds : P->dspread;
    }
}

void sc_top_trace_packet(const sc_top *T, uint32_t lanes, const float *rows, unsigned W, void *out, int any,
                         sc_trace_stats *st)
{
    top_packet P;
    P.T = T, P.W = W, P.any = any, P.st = st, P.active = lanes;
    P.occluded = any ? out : NULL;
    for (uint32_t e = lanes; e; e &= e - 1) {
        const unsigned l = (unsigned)__builtin_ctz(e);
        sc_ray *r = &P.ray[l];
        *r = (sc_ray){ { rows[l], rows[W + l], rows[2 * W + l] }, rows[3 * W + l],
                       { rows[4 * W + l], rows[5 * W + l], rows[6 * W + l] }, rows[7 * W + l] };
        if (any) {
            P.occluded[l] = 0;
        } else {
            sc_hitrec *h = &P.best[l];
            memset(h, 0, sizeof *h);
            h->t = r->tmax;
            h->prim = SC_HITREC_MISS;
            h->geom = h->inst = SC_INVALID_ID;
        }
    }
    top_packet_spread(&P, lanes);
    float c[3], h2 = 0;
    for (int k = 0; k < 3; k++) {
        c[k] = 0.5f * (T->lo[k] + T->hi[k]);
        h2 += 0.25f * (T->hi[k] - T->lo[k]) * (T->hi[k] - T->lo[k]);
    }
    if (!top_packet_narrow(&P, c, sqrtf(h2))) {
        /* wide against the whole scene: lane by lane through the single-ray top kernel */
        const sc_trace_kernels *k = &sc_kernels_active()->trace[0];
        for (uint32_t e = lanes; e; e &= e - 1) {
            const unsigned l = (unsigned)__builtin_ctz(e);
            if (any)
                P.occluded[l] = k->top_any(T, &P.ray[l], st);
            else
                k->top_closest(T, &P.ray[l], &P.best[l], st);
        }
        goto done;
    }
    for (uint32_t e = lanes; e; e &= e - 1) {
        const unsigned l = (unsigned)__builtin_ctz(e);
        double m;
        sc_top_ray_setup(&P.ray[l], sc_top_grow(T, &P.ray[l], &m), &P.tr[l]);
        P.tcull[l] = P.ray[l].tmax;
    }
    /* Each node pushes at most its 8 children, as in the single-ray walk,
     * so the single-ray stack bound holds. */
    top_entry stack[SC_TRACE_STACK];
    int sp = 0;
    stack[sp++] = (top_entry){ 0, lanes };
    while (sp && P.active) {
        const top_entry e = stack[--sp];
        const uint32_t L = e.lanes & P.active;
        if (!L)
            continue;
        if (sc_ref_is_leaf(e.ref)) {
            top_packet_visit(&P, (uint32_t)(e.ref & 0xffffffffu), L);
            continue;
        }
        const sc_bvh_node8 *node = &T->nodes[e.ref];
        if (st)
            st->nodes++;
        uint32_t cl[SC_BVH_N] = { 0 };
        float cd[SC_BVH_N];
        for (int i = 0; i < SC_BVH_N; i++)
            cd[i] = INFINITY;
        for (uint32_t b = L; b; b &= b - 1) {
            const unsigned l = (unsigned)__builtin_ctz(b);
            _Alignas(16) float dist[SC_BVH_N];
            for (unsigned m = sc_top_slab(&P.tr[l], node, P.ray[l].tmin, P.tcull[l], dist); m; m &= m - 1) {
                const int i = __builtin_ctz(m);
                cl[i] |= 1u << l;
                cd[i] = dist[i] < cd[i] ? dist[i] : cd[i];
            }
        }
        /* the children some lane reached, far to near: the nearest is
         * popped first */
        int idx[SC_BVH_N], n = 0;
        for (int i = 0; i < SC_BVH_N; i++) {
            if (!cl[i])
                continue;
            int j = n++;
            while (j > 0 && cd[idx[j - 1]] < cd[i]) {
                idx[j] = idx[j - 1];
                j--;
            }
            idx[j] = i;
        }
        for (int j = 0; j < n; j++)
            stack[sp++] = (top_entry){ node->child[idx[j]], cl[idx[j]] };
    }
done:
    if (!any)
        for (uint32_t e = lanes; e; e &= e - 1) {
            const unsigned l = (unsigned)__builtin_ctz(e);
            sc_hit_lane_put(out, W, l, &P.best[l]);
        }
}

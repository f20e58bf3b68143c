/* The top level of a two-level scene for packets, one body for every ISA:
 * included by traverse_bvh8_single.h after the single-ray top level
 * (traverse_top_bvh8.h: top_closest, top_any, SC_TOP_TABLE). The packet
 * walks the top tree together; the lanes that reach an instance go through
 * its tree as one packet of object rays (sc_trace_packet_lanes), each
 * ending where sc_top_item_tmax says (one float past its closest hit so
 * far, or the ray's own end for the exact test). The per-lane work (set-up, box tests,
 * object rays) is written over the lanes in rows, so the ISA's vectors take
 * 4, 8 or 16 lanes at a time. Lane i's answer is bit for bit the single-ray
 * top kernel's for ray i (of the hits the smallest t, then inst, geom,
 * prim, whatever order the instances are reached in).
 *
 * A packet pays where its rays stay together through a tree, that is where
 * the packet is narrow next to what it is tracing. Its width at distance D
 * from its first origin is about ospread + dspread D (the spread of its
 * origins, and of its directions scaled to unit L1 length); against an
 * item of half diagonal h (its world box) the packet goes on as one packet
 * of object rays only while that width is at most SC_TOP_PACKET_SPREAD h,
 * and lane by lane through the single-ray kernels otherwise; against the
 * whole scene the same test decides whether the packet walks the top tree
 * at all, or each lane takes the single-ray top kernel. A camera tile seen
 * against 8 large instances of a 100k-triangle mesh passes; the same tile
 * against 1,000 small ones (each a few tiles on screen) fails at the
 * instances, where the packet kernel ran at 0.85x the single rays; a tile's
 * diffuse bounces fail at the root (docs/scenes.md). The answers are the
 * same either way. */
#include <float.h>

#include "trace_packet.h"

#define SC_TOP_PACKET_SPREAD 0.1f

typedef struct top_pk {
    /* the world rays, rows of 16 lanes */
    float o[3][16] __attribute__((aligned(64)));
    float d[3][16] __attribute__((aligned(64)));
    float tmin[16] __attribute__((aligned(64)));
    float tmax[16] __attribute__((aligned(64)));
    /* the grown-box test of sc_top_slab, lane by lane: fl(1/d), E |1/d|, d < 0 */
    float rd[3][16] __attribute__((aligned(64)));
    float Ek[3][16] __attribute__((aligned(64)));
    int32_t neg[3][16] __attribute__((aligned(64)));
    uint32_t negm[3];                                /* the same as lane bits */
    float tcull[16] __attribute__((aligned(64)));   /* sc_top_tmax: how far boxes are tested */
    sc_hitrec best[16];                              /* closest */
    int32_t *occluded;                               /* any */
    const sc_top *T;
    unsigned W;
    uint32_t active;                                 /* lanes still looking (any: not occluded) */
    float o0[3], ospread, dspread;
    int any;
    sc_trace_stats *st;
} top_pk;

typedef struct top_pk_entry {
    uint64_t ref;
    uint32_t lanes;
} top_pk_entry;

/* Whether the packet is narrow next to a box of centre c and half diagonal h. */
SC_TRAVERSE_INLINE int top_pk_narrow(const top_pk *P, const float c[3], float h)
{
    float D = 0;
    for (int k = 0; k < 3; k++) {
        const float dk = fabsf(c[k] - P->o0[k]);
        D = dk > D ? dk : D;
    }
    return P->ospread + P->dspread * D <= SC_TOP_PACKET_SPREAD * h;
}

/* A hit h of item it for lane l: kept if it beats the lane's best. */
SC_TRAVERSE_INLINE void top_pk_offer(top_pk *P, const sc_top_item *it, const sc_bvh *b, unsigned l, sc_hitrec *h)
{
    sc_top_map_ids(b, h);
    if (h->prim != SC_HITREC_MISS)
        h->inst = it->inst;
    if (sc_top_better(h, &P->best[l])) {
        if (it->inv)
            sc_top_normal(it->cof, h->ng);
        P->best[l] = *h;
        P->tcull[l] = sc_top_tmax(h, P->tmax[l]);
    }
}

SC_TRAVERSE_INLINE void top_pk_occluded(top_pk *P, unsigned l)
{
    P->occluded[l] = 1;
    P->active &= ~(1u << l);
}

/* The lanes L that reached item `item`: their object rays (sc_top_object_ray
 * lane by lane) as one packet, or one by one where the packet is wide next
 * to the item. */
SC_TRAVERSE_INLINE void top_pk_visit(top_pk *P, uint32_t item, uint32_t L)
{
    const sc_top_item *it = &P->T->items[item];
    const sc_bvh *b = *it->bvh;
    if (!b)
        return;
    const unsigned W = P->W;
    float rows[8][16] __attribute__((aligned(64)));
    int32_t valid[16];
    if (it->inv) {
        const double *m = it->inv;
        for (int l = 0; l < 16; l++)
            for (int i = 0; i < 3; i++) {
                rows[i][l] = sc_top_xfm_point(m + 4 * i, P->o[0][l], P->o[1][l], P->o[2][l]);
                rows[4 + i][l] = sc_top_xfm_dir(m + 4 * i, P->d[0][l], P->d[1][l], P->d[2][l]);
            }
        /* sc_ray_valid of each object ray */
        for (int l = 0; l < 16; l++) {
            int ok = 1;
            for (int k = 0; k < 3; k++)
                ok &= fabsf(rows[k][l]) < SC_MAX_ORIGIN && fabsf(rows[4 + k][l]) <= FLT_MAX;
            ok &= rows[4][l] != 0 || rows[5][l] != 0 || rows[6][l] != 0;
            valid[l] = ok;
        }
    } else {
        for (int l = 0; l < 16; l++) {
            for (int k = 0; k < 3; k++)
                rows[k][l] = P->o[k][l], rows[4 + k][l] = P->d[k][l];
            valid[l] = 1;
        }
    }
    uint32_t ok = 0;
    for (uint32_t e = L; e; e &= e - 1) {
        const unsigned l = (unsigned)__builtin_ctz(e);
        ok |= (uint32_t)(valid[l] != 0) << l;
        rows[3][l] = P->tmin[l];
        rows[7][l] = P->any ? P->tmax[l] : sc_top_item_tmax(b, &P->best[l], P->tmax[l]);
    }
    if (!ok)
        return;
    sc_trace_stats s;
    memset(&s, 0, sizeof s);
    sc_trace_stats *sp = P->st ? &s : NULL;
    if (!top_pk_narrow(P, it->center, it->half)) {
        const sc_trace_kernels *k = &SC_TOP_TABLE[b->cfg.tri_test];
        for (uint32_t e = ok; e; e &= e - 1) {
            const unsigned l = (unsigned)__builtin_ctz(e);
            const sc_ray r = { { rows[0][l], rows[1][l], rows[2][l] }, rows[3][l],
                               { rows[4][l], rows[5][l], rows[6][l] }, rows[7][l] };
            if (P->any) {
                if (sp ? k->any_stats(b, &r, sp) : k->any(b, &r))
                    top_pk_occluded(P, l);
            } else {
                sc_hitrec h;
                if (sp)
                    k->closest_stats(b, &r, &h, sp);
                else
                    k->closest(b, &r, &h);
                top_pk_offer(P, it, b, l, &h);
            }
        }
    } else {
        /* W-lane rows for the kernels, which load whole rows: lanes not
         * traced repeat a traced one */
        float pk[8 * 16] __attribute__((aligned(64)));
        const unsigned f = (unsigned)__builtin_ctz(ok);
        for (unsigned k = 0; k < 8; k++)
            for (unsigned l = 0; l < W; l++)
                pk[k * W + l] = rows[k][ok >> l & 1 ? l : f];
        if (P->any) {
            int32_t occ[16];
            sc_trace_packet_lanes(b, ok, pk, W, occ, 1, sp);
            for (uint32_t e = ok; e; e &= e - 1) {
                const unsigned l = (unsigned)__builtin_ctz(e);
                if (occ[l])
                    top_pk_occluded(P, l);
            }
        } else {
            sc_hit_packet16 hp;
            sc_trace_packet_lanes(b, ok, pk, W, &hp, 0, sp);
            for (uint32_t e = ok; e; e &= e - 1) {
                const unsigned l = (unsigned)__builtin_ctz(e);
                sc_hitrec h;
                sc_hit_lane_get(&hp, W, l, &h);
                top_pk_offer(P, it, b, l, &h);
            }
        }
    }
    /* the objects' counters, but not their rays: the caller counts each ray once */
    if (P->st)
        P->st->nodes += s.nodes, P->st->leaves += s.leaves, P->st->sphere_tests += s.sphere_tests,
            P->st->sphere_rejects += s.sphere_rejects, P->st->tri_tests += s.tri_tests, P->st->tri_hits += s.tri_hits;
}

/* The packet's first origin and its spreads. */
SC_TRAVERSE_INLINE void top_pk_spread(top_pk *P, uint32_t lanes)
{
    float ulo[3], uhi[3], olo[3], ohi[3];
    const unsigned f0 = (unsigned)__builtin_ctz(lanes);
    for (int k = 0; k < 3; k++)
        ulo[k] = olo[k] = INFINITY, uhi[k] = ohi[k] = -INFINITY, P->o0[k] = P->o[k][f0];
    for (uint32_t e = lanes; e; e &= e - 1) {
        const unsigned l = (unsigned)__builtin_ctz(e);
        const float inv = 1 / (fabsf(P->d[0][l]) + fabsf(P->d[1][l]) + fabsf(P->d[2][l]));
        for (int k = 0; k < 3; k++) {
            /* compares, not fminf/fmaxf: those are calls at the baseline level */
            const float u = P->d[k][l] * inv, o = P->o[k][l];
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

/* The grown-box test of sc_top_slab for every lane and child: mask[i] the
 * lanes (of L) that reach child i, dist[i] the nearest of their entries. */
#ifdef SC_TOP_VP
/* In the ISA's vectors (SC_TOP_VP: a simd_vec.h shape of 8 or 16 lanes),
 * with the lane masks and the nearest entry from mask registers: GCC
 * vectorises the portable form's box test but not its per-lane gathering
 * of the masks, whose branches were half of the top level's time. The
 * same operations in the same order, so the same bits. */
#define TCAT_(a, b) a##_##b
#define TCAT(a, b) TCAT_(a, b)
#define TV(op) TCAT(SC_TOP_VP, op)
SC_TRAVERSE_INLINE void top_pk_node(const top_pk *P, const sc_bvh_node8 *node, uint32_t L, uint32_t mask[SC_BVH_N],
                                    float dist[SC_BVH_N])
{
    enum { VW = TV(N) };
    const TV(t) down = TV(set1)(1.0f - 0x1p-21f), up = TV(set1)(1.0f + 0x1p-21f), eps = TV(set1)(0x1p-122f);
    const TV(t) inf = TV(set1)(INFINITY);
    for (int i = 0; i < SC_BVH_N; i++) {
        uint32_t m = 0;
        float dmin = INFINITY;
        for (unsigned h = 0; h < 16; h += VW) {
            TV(t) a = TV(load)(P->tmin + h), b = TV(load)(P->tcull + h);
            for (int k = 0; k < 3; k++) {
                const TV(t) bl = TV(set1)(node->b[2 * k][i]), bh = TV(set1)(node->b[2 * k + 1][i]);
                const TV(m) ng = TV(mask_from_bits)(P->negm[k] >> h);
                const TV(t) nr = TV(sel)(ng, bh, bl), fr = TV(sel)(ng, bl, bh);
                const TV(t) o = TV(load)(P->o[k] + h), rd = TV(load)(P->rd[k] + h), e = TV(load)(P->Ek[k] + h);
                /* max/min return the second operand for a NaN: the bound stays */
                a = TV(max)(TV(sub)(TV(mul)(TV(sub)(nr, o), rd), e), a);
                b = TV(min)(TV(add)(TV(mul)(TV(sub)(fr, o), rd), e), b);
            }
            const TV(t) lo = TV(sub)(TV(mul)(a, down), eps);
            const uint32_t hm = TV(bits)(TV(le)(lo, TV(add)(TV(mul)(b, up), eps))) & (L >> h) & ((1u << VW) - 1);
            if (hm) {
                m |= hm << h;
                const float d = TV(hmin)(TV(sel)(TV(mask_from_bits)(hm), lo, inf));
                dmin = d < dmin ? d : dmin;
            }
        }
        mask[i] = m;
        dist[i] = dmin;
    }
}
#undef TV
#undef TCAT
#undef TCAT_
#else
SC_TRAVERSE_INLINE void top_pk_node(const top_pk *P, const sc_bvh_node8 *node, uint32_t L, uint32_t mask[SC_BVH_N],
                                    float dist[SC_BVH_N])
{
    for (int i = 0; i < SC_BVH_N; i++) {
        float lo[16] __attribute__((aligned(64)));
        int32_t hit[16] __attribute__((aligned(64)));
        for (int l = 0; l < 16; l++) {
            float a = P->tmin[l], b = P->tcull[l];
            for (int k = 0; k < 3; k++) {
                const float bl = node->b[2 * k][i], bh = node->b[2 * k + 1][i];
                const float nr = P->neg[k][l] ? bh : bl, fr = P->neg[k][l] ? bl : bh;
                const float tn = (nr - P->o[k][l]) * P->rd[k][l] - P->Ek[k][l];
                const float tf = (fr - P->o[k][l]) * P->rd[k][l] + P->Ek[k][l];
                a = tn > a ? tn : a;   /* a NaN (a ray in a slab's plane) keeps the bound */
                b = tf < b ? tf : b;
            }
            lo[l] = a * (1.0f - 0x1p-21f) - 0x1p-122f;
            hit[l] = lo[l] <= b * (1.0f + 0x1p-21f) + 0x1p-122f;
        }
        uint32_t m = 0;
        float dmin = INFINITY;
        for (uint32_t e = L; e; e &= e - 1) {
            const unsigned l = (unsigned)__builtin_ctz(e);
            if (hit[l]) {
                m |= 1u << l;
                dmin = lo[l] < dmin ? lo[l] : dmin;
            }
        }
        mask[i] = m;
        dist[i] = dmin;
    }
}
#endif

/* Lanes `lanes` (checked rays) of a W-lane packet (rows as
 * sc_trace_packet_lanes) through the top level; out as there (closest: the
 * traced lanes' hits, misses included, written at the end). Statistics: the packet's top nodes and the
 * object packets' counters, not the rays (the caller counts each once). */
static SC_TARGET void top_packet(const sc_top *T, uint32_t lanes, const float *rows, unsigned W, void *out, int any,
                                 sc_trace_stats *st)
{
    if (!lanes)
        return;
    top_pk P;
    P.T = T, P.W = W, P.any = any, P.st = st, P.active = lanes;
    P.occluded = any ? out : NULL;
    /* every lane of the rows, traced or not, so that the loops below run
     * over all 16; the lanes not traced repeat the first traced one */
    const unsigned f0 = (unsigned)__builtin_ctz(lanes);
    for (int l = 0; l < 16; l++) {
        const unsigned src = (unsigned)l < W && (lanes >> l & 1) ? (unsigned)l : f0;
        for (int k = 0; k < 3; k++)
            P.o[k][l] = rows[k * W + src], P.d[k][l] = rows[(4 + k) * W + src];
        P.tmin[l] = rows[3 * W + src], P.tmax[l] = rows[7 * W + src];
    }
    for (uint32_t e = lanes; e; e &= e - 1) {
        const unsigned l = (unsigned)__builtin_ctz(e);
        if (any) {
            P.occluded[l] = 0;
        } else {
            sc_top_miss(P.tmax[l], &P.best[l]);
        }
    }
    top_pk_spread(&P, lanes);
    if (!top_pk_narrow(&P, T->center, T->half)) {
        /* wide against the whole scene: lane by lane through the single-ray top level */
        for (uint32_t e = lanes; e; e &= e - 1) {
            const unsigned l = (unsigned)__builtin_ctz(e);
            const sc_ray r = { { P.o[0][l], P.o[1][l], P.o[2][l] }, P.tmin[l],
                               { P.d[0][l], P.d[1][l], P.d[2][l] }, P.tmax[l] };
            if (any)
                P.occluded[l] = top_any(T, &r, st);
            else
                top_closest(T, &r, &P.best[l], st);
        }
        goto done;
    }
    /* sc_top_grow and sc_top_ray_setup, lane by lane */
    P.negm[0] = P.negm[1] = P.negm[2] = 0;
    for (int l = 0; l < 16; l++) {
        double m = 0;
        for (int k = 0; k < 3; k++) {
            const double dl = fabs((double)T->lo[k] - P.o[k][l]), dh = fabs((double)T->hi[k] - P.o[k][l]);
            m = dl > m ? dl : m;
            m = dh > m ? dh : m;
        }
        const double E = sc_top_growth(T, m);
        for (int k = 0; k < 3; k++) {
            P.rd[k][l] = 1.0f / P.d[k][l];
            P.Ek[k][l] = sc_top_ek(E, P.rd[k][l]);
            P.neg[k][l] = signbit(P.d[k][l]) != 0;
            P.negm[k] |= (uint32_t)P.neg[k][l] << l;
        }
        P.tcull[l] = P.tmax[l];
    }
    /* Each node pushes at most its 8 children, as in the single-ray walk,
     * so the single-ray stack bound holds. */
    top_pk_entry stack[SC_TRACE_STACK];
    int sp = 0;
    stack[sp++] = (top_pk_entry){ 0, lanes };
    while (sp && P.active) {
        const top_pk_entry e = stack[--sp];
        const uint32_t L = e.lanes & P.active;
        if (!L)
            continue;
        if (sc_ref_is_leaf(e.ref)) {
            top_pk_visit(&P, (uint32_t)(e.ref & 0xffffffffu), L);
            continue;
        }
        const sc_bvh_node8 *node = &T->nodes[e.ref];
        if (st)
            st->nodes++;
        uint32_t cl[SC_BVH_N];
        float cd[SC_BVH_N];
        top_pk_node(&P, node, L, cl, cd);
        /* the children some lane reached, far to near: the nearest is popped first */
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
            stack[sp++] = (top_pk_entry){ node->child[idx[j]], cl[idx[j]] };
    }
done:
    if (!any)
        for (uint32_t e = lanes; e; e &= e - 1) {
            const unsigned l = (unsigned)__builtin_ctz(e);
            sc_hit_lane_put(out, W, l, &P.best[l]);
        }
}

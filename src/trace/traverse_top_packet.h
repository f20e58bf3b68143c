/* The top level of a two-level scene for packets, one body for every ISA:
 * included by traverse_bvh8_single.h after the single-ray top level
 * (traverse_top_bvh8.h: top_closest, top_any, SC_TOP_TABLE). The packet
 * walks the top tree together; the lanes that reach an instance go through
 * its tree as one packet of object rays (sc_trace_packet_lanes), each
 * ending where sc_top_item_tmax says (one float past its closest hit so
 * far, or the ray's own end for the exact test). Lane i's answer is bit
 * for bit the single-ray top kernel's for ray i (of the hits the smallest
 * t, then inst, geom, prim, whatever order the instances are reached in).
 *
 * The box tests are the single ray's FMA test (sc_top_pre's constants, the
 * growth folded into the padding) over the lanes in vectors (SC_TOP_VP,
 * 8 lanes wide on both x86 levels: traverse_bvh8_x86.h says why); a
 * packet whose lanes share an octant first tests the node's 8 children
 * against its frustum in one 8-wide test, and only the children that pass
 * lane by lane (as the BVHs' own packets do, traverse_bvh8_packet.h). The
 * object rays of an instance are made for all lanes at once (SC_TOP_XFM16,
 * in double) and used for the lanes that reach it. Lanes
 * parallel to an axis take the single-ray top kernel.
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
 * instances, where the packet kernel ran at 0.85x the single rays. A
 * tile's diffuse bounces pass where they start: inside the scene's box
 * and inside the item they left, from origins within SC_TOP_PACKET_SPREAD
 * h of each other (top_pk_narrow), and fail elsewhere (docs/scenes.md).
 * The answers are the same either way. */
#include <float.h>

#include "trace_packet.h"

#ifdef SC_TOP_VP
#define TCAT_(a, b) a##_##b
#define TCAT(a, b) TCAT_(a, b)
#define TV(op) TCAT(SC_TOP_VP, op)
#endif

#define SC_TOP_PACKET_SPREAD 0.1f

typedef struct top_pk {
    /* the world rays, rows of 16 lanes (lanes not traced repeat a traced one) */
    float o[3][16] __attribute__((aligned(64)));
    float d[3][16] __attribute__((aligned(64)));
    float tmin[16] __attribute__((aligned(64)));
    float tmax[16] __attribute__((aligned(64)));
    /* the FMA box test of each lane (sc_top_pre) */
    float rd[3][16] __attribute__((aligned(64)));
    float ordn[3][16] __attribute__((aligned(64)));
    float ordf[3][16] __attribute__((aligned(64)));
    float tcull[16] __attribute__((aligned(64)));   /* sc_top_tmax: how far boxes are tested */
    float om[16], dm[16];                            /* sc_top_ray_extent of each lane */
    uint32_t negm[3];                                /* lanes with d_k < 0 */
    int uniform, oct;                                /* every lane in octant oct */
    /* a uniform packet's frustum: the extreme rd and offsets over the lanes */
    float fr_rdmin[3], fr_rdmax[3], fr_onmax[3], fr_ofmin[3], fr_tmin, fr_tmax;
    /* closest: each lane's best hit so far, rows as sc_hit_packet16 (t u v
     * prim ngx ngy ngz geom inst), so that an object packet's hits merge in
     * vectors and the answer is stored as rows */
    float hit[9][16] __attribute__((aligned(64)));
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
    uint32_t from;   /* the top node it is a child of and its slot (index << 3 | slot) */
} top_pk_entry;

/* Whether the packet is narrow next to a box of centre c and half
 * diagonal h, or starts inside it from origins close together: bounce
 * rays from a tile's hits on the item itself, which share the item's
 * nodes around their origins whatever their directions, as the BVHs' own
 * packets of such rays do (one instance, diffuse packets: 12-15 % faster
 * than lane by lane; docs/scenes.md). */
SC_TRAVERSE_INLINE int top_pk_narrow(const top_pk *P, const float c[3], float h)
{
    float D = 0;
    for (int k = 0; k < 3; k++) {
        const float dk = fabsf(c[k] - P->o0[k]);
        D = dk > D ? dk : D;
    }
    if (D <= h && P->ospread <= SC_TOP_PACKET_SPREAD * h)
        return 1;
    return P->ospread + P->dspread * D <= SC_TOP_PACKET_SPREAD * h;
}

/* A hit h of item it for lane l: kept if it beats the lane's best. */
SC_TRAVERSE_INLINE void top_pk_offer(top_pk *P, const sc_top_item *it, const sc_bvh *b, unsigned l, sc_hitrec *h)
{
    sc_hitrec best;
    sc_hit_lane_get(P->hit, 16, l, &best);
    if (sc_top_offer(it, b, h, &best)) {
        sc_hit_lane_put(P->hit, 16, l, &best);
        P->tcull[l] = sc_top_tmax(h, P->tmax[l]);
    }
}

#ifdef SC_TOP_VP
/* The hits of an object packet (rows of W lanes, src) of item it, whose
 * BVH holds one mesh, for lanes L: sc_top_offer lane by lane, in vectors.
 * A hit wins where the lane has none yet or where it is nearer; at equal t
 * the ids decide, lane by lane (sc_top_better). The normal is taken to
 * world space as sc_top_normal does, in the same order of operations, so
 * the same bits. */
SC_TRAVERSE_INLINE void top_pk_merge(top_pk *P, const sc_top_item *it, const float *src, unsigned W, uint32_t L)
{
    enum { VW = TV(N) };
    const TV(t) miss = TV(set1_bits)(SC_HITREC_MISS);
    for (unsigned h = 0; h < W; h += VW) {
        const uint32_t m = (L >> h) & ((1u << VW) - 1);
        if (!m)
            continue;
        const TV(t) nt = TV(load)(src + h), bt = TV(load)(P->hit[0] + h);
        const uint32_t nhit = m & ~TV(bits)(TV(eq_bits)(TV(load)(src + 3 * W + h), miss));
        if (!nhit)
            continue;
        const uint32_t bmiss = TV(bits)(TV(eq_bits)(TV(load)(P->hit[3] + h), miss));
        uint32_t better = nhit & (bmiss | TV(bits)(TV(lt)(nt, bt)));
        for (uint32_t e = nhit & ~better & TV(bits)(TV(eq)(nt, bt)); e; e &= e - 1) {
            const unsigned l = h + (unsigned)__builtin_ctz(e);
            sc_hitrec nh, bh;
            sc_hit_lane_get(src, W, l, &nh);
            nh.inst = it->inst;
            sc_hit_lane_get(P->hit, 16, l, &bh);
            if (sc_top_better(&nh, &bh))
                better |= 1u << (l - h);
        }
        if (!better)
            continue;
        const TV(m) M = TV(mask_from_bits)(better);
        static const int rows[5] = { 0, 1, 2, 3, 7 };
        for (int r = 0; r < 5; r++)
            TV(store)(P->hit[rows[r]] + h,
                      TV(sel)(M, TV(load)(src + (unsigned)rows[r] * W + h), TV(load)(P->hit[rows[r]] + h)));
        TV(store)(P->hit[8] + h, TV(sel)(M, TV(set1_bits)(it->inst), TV(load)(P->hit[8] + h)));
        TV(t) n[3] = { TV(load)(src + 4 * W + h), TV(load)(src + 5 * W + h), TV(load)(src + 6 * W + h) };
        if (it->inv) {
            const float *c = it->cof;
            TV(t) g[3];
            for (int i = 0; i < 3; i++)
                g[i] = TV(add)(TV(add)(TV(mul)(TV(set1)(c[3 * i]), n[0]), TV(mul)(TV(set1)(c[3 * i + 1]), n[1])),
                               TV(mul)(TV(set1)(c[3 * i + 2]), n[2]));
            for (int i = 0; i < 3; i++)
                n[i] = g[i];
        }
        for (int i = 0; i < 3; i++)
            TV(store)(P->hit[4 + i] + h, TV(sel)(M, n[i], TV(load)(P->hit[4 + i] + h)));
        for (uint32_t e = better; e; e &= e - 1) {
            const unsigned l = h + (unsigned)__builtin_ctz(e);
            P->tcull[l] = sc_top_tmax_t(P->hit[0][l], P->tmax[l]);
        }
    }
}
#endif

/* Lane l's world ray, ending at tmax. */
SC_TRAVERSE_INLINE sc_ray top_pk_ray(const top_pk *P, unsigned l, float tmax)
{
    const sc_ray r = { { P->o[0][l], P->o[1][l], P->o[2][l] }, P->tmin[l], { P->d[0][l], P->d[1][l], P->d[2][l] }, tmax };
    return r;
}

SC_TRAVERSE_INLINE void top_pk_occluded(top_pk *P, unsigned l)
{
    P->occluded[l] = 1;
    P->active &= ~(1u << l);
}

/* The object rays of lanes L against item it (rows ox oy oz tmin dx dy dz
 * tmax of 16 lanes; every lane is computed, those outside L are not read):
 * each lane's sc_top_object_ray, as the single-ray walk makes it, ending
 * where sc_top_item_tmax says (tcull is sc_top_tmax of the lane's best hit;
 * an any-hit packet keeps tcull = tmax). Returns the lanes of L whose object
 * ray is valid. */
SC_TRAVERSE_INLINE uint32_t top_pk_objects(const top_pk *P, const sc_top_item *it, const sc_bvh *b, uint32_t L,
                                           float ob[8][16])
{
    const float *tmax = b->cfg.tri_test == SC_TRI_EXACT ? P->tmax : P->tcull;
#if defined(SC_TOP_XFM16) && defined(SC_TOP_VP)
    enum { VW = TV(N) };
    for (unsigned h = 0; h < 16; h += VW) {
        TV(store)(ob[3] + h, TV(load)(P->tmin + h));
        TV(store)(ob[7] + h, TV(load)(tmax + h));
        if (!it->inv)
            for (int k = 0; k < 3; k++)
                TV(store)(ob[k] + h, TV(load)(P->o[k] + h)), TV(store)(ob[4 + k] + h, TV(load)(P->d[k] + h));
    }
    if (!it->inv)
        return L;
    SC_TOP_XFM16(it->inv, P->o, P->d, ob);
    uint32_t sure = 0;
    for (unsigned h = 0; h < 16; h += VW) {
        const TV(t) om = TV(load)(P->om + h), dm = TV(load)(P->dm + h);
        const TV(m) s = TV(and)(TV(and)(TV(le)(om, TV(set1)(it->vo)), TV(le)(dm, TV(set1)(it->vdhi))),
                                TV(ge)(dm, TV(set1)(it->vdlo)));
        sure |= TV(bits)(s) << h;
    }
#else
    for (uint32_t e = L; e; e &= e - 1) {
        const unsigned l = (unsigned)__builtin_ctz(e);
        const sc_ray w = top_pk_ray(P, l, tmax[l]);
        sc_ray r = w;
        if (it->inv)
            sc_top_object_ray(it->inv, &w, &r);
        for (int k = 0; k < 3; k++)
            ob[k][l] = r.org[k], ob[4 + k][l] = r.dir[k];
        ob[3][l] = r.tmin, ob[7][l] = r.tmax;
    }
    if (!it->inv)
        return L;
    uint32_t sure = 0;
    for (uint32_t e = L; e; e &= e - 1) {
        const unsigned l = (unsigned)__builtin_ctz(e);
        sure |= (uint32_t)sc_top_surely_valid(it, P->om[l], P->dm[l]) << l;
    }
#endif
    uint32_t ok = L;
    for (uint32_t e = L & ~sure; e; e &= e - 1) {
        const unsigned l = (unsigned)__builtin_ctz(e);
        const sc_ray r = { { ob[0][l], ob[1][l], ob[2][l] }, ob[3][l], { ob[4][l], ob[5][l], ob[6][l] }, ob[7][l] };
        if (!sc_ray_valid(&r))
            ok &= ~(1u << l);
    }
    return ok;
}

/* The lanes L that reached item `item`: their object rays
 * (top_pk_objects), traced one by one through the single-ray kernel where
 * the packet is wide next to the item, else as one packet of object rays. */
SC_TRAVERSE_INLINE void top_pk_visit(top_pk *P, uint32_t item, uint32_t L)
{
    const sc_top_item *it = &P->T->items[item];
    const sc_bvh *b = *it->bvh;
    if (!b)
        return;
    const unsigned W = P->W;
    sc_trace_stats s;
    if (P->st)
        memset(&s, 0, sizeof s);
    sc_trace_stats *sp = P->st ? &s : NULL;
    float ob[8][16] __attribute__((aligned(64)));
    const uint32_t ok = top_pk_objects(P, it, b, L, ob);
    if (!ok)
        goto done;
    if (!top_pk_narrow(P, it->center, it->half)) {
        /* lanes in several octants take the one-body kernels, as
         * top_packet's lanes traced one by one do (top_closest_walk) */
        const sc_trace_kernels *k = &SC_TOP_TABLE[b->cfg.tri_test];
        const int inc = !P->uniform;
        for (uint32_t e = ok; e; e &= e - 1) {
            const unsigned l = (unsigned)__builtin_ctz(e);
            const sc_ray r = { { ob[0][l], ob[1][l], ob[2][l] }, ob[3][l], { ob[4][l], ob[5][l], ob[6][l] }, ob[7][l] };
            if (P->any) {
                if (sp ? k->any_stats(b, &r, sp) : inc ? k->any_incoherent(b, &r) : k->any(b, &r))
                    top_pk_occluded(P, l);
            } else {
                sc_hitrec h;
                if (sp)
                    k->closest_stats(b, &r, &h, sp);
                else if (inc)
                    k->closest_incoherent(b, &r, &h);
                else
                    k->closest(b, &r, &h);
                top_pk_offer(P, it, b, l, &h);
            }
        }
        goto done;
    }
    /* W-lane rows for the packet kernels, which load whole rows: lanes not
     * traced repeat a traced one */
    float pk[8 * 16] __attribute__((aligned(64)));
    const unsigned f = (unsigned)__builtin_ctz(ok);
#ifdef SC_TOP_VP
    if (W >= TV(N)) {
        for (unsigned r = 0; r < 8; r++)
            for (unsigned h = 0; h < W; h += TV(N))
                TV(store)(pk + r * W + h, TV(sel)(TV(mask_from_bits)(ok >> h), TV(load)(ob[r] + h), TV(set1)(ob[r][f])));
    } else
#endif
    {
        for (unsigned r = 0; r < 8; r++)
            for (unsigned l = 0; l < W; l++)
                pk[r * W + l] = ob[r][ok >> l & 1 ? l : f];
    }
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
#ifdef SC_TOP_VP
        if (b->mesh_count < 2) {
            top_pk_merge(P, it, (const float *)(const void *)&hp, W, ok);
            goto done;
        }
#endif
        for (uint32_t e = ok; e; e &= e - 1) {
            const unsigned l = (unsigned)__builtin_ctz(e);
            sc_hitrec h;
            sc_hit_lane_get(&hp, W, l, &h);
            top_pk_offer(P, it, b, l, &h);
        }
    }
done:
    if (P->st)
        sc_top_add_counters(P->st, &s);
}

/* The smallest and largest value of a 16-lane row over lanes L (+inf and
 * -inf for none), and each lane's direction scaled to unit L1 length. */
#ifdef SC_TOP_VP
SC_TRAVERSE_INLINE float top_pk_row_min(const float *row, uint32_t L)
{
    const TV(t) pinf = TV(set1)(INFINITY);
    TV(t) lo = pinf;
    for (unsigned h = 0; h < 16; h += TV(N))
        lo = TV(min)(lo, TV(sel)(TV(mask_from_bits)(L >> h), TV(load)(row + h), pinf));
    return TV(hmin)(lo);
}

SC_TRAVERSE_INLINE float top_pk_row_max(const float *row, uint32_t L)
{
    const TV(t) pinf = TV(set1)(INFINITY), zero = TV(set1)(0);
    TV(t) lo = pinf;   /* of the negated values */
    for (unsigned h = 0; h < 16; h += TV(N))
        lo = TV(min)(lo, TV(sel)(TV(mask_from_bits)(L >> h), TV(sub)(zero, TV(load)(row + h)), pinf));
    return -TV(hmin)(lo);
}

SC_TRAVERSE_INLINE void top_pk_unit_dirs(const top_pk *P, float u[3][16])
{
    for (unsigned h = 0; h < 16; h += TV(N)) {
        const TV(t) n = TV(add)(TV(add)(TV(abs)(TV(load)(P->d[0] + h)), TV(abs)(TV(load)(P->d[1] + h))),
                               TV(abs)(TV(load)(P->d[2] + h)));
        const TV(t) inv = TV(div)(TV(set1)(1.0f), n);
        for (int k = 0; k < 3; k++)
            TV(store)(u[k] + h, TV(mul)(TV(load)(P->d[k] + h), inv));
    }
}
#else
/* compares, not fminf/fmaxf: those are calls at the baseline level */
SC_TRAVERSE_INLINE float top_pk_row_min(const float *row, uint32_t L)
{
    float lo = INFINITY;
    for (uint32_t e = L; e; e &= e - 1) {
        const unsigned l = (unsigned)__builtin_ctz(e);
        lo = row[l] < lo ? row[l] : lo;
    }
    return lo;
}

SC_TRAVERSE_INLINE float top_pk_row_max(const float *row, uint32_t L)
{
    float hi = -INFINITY;
    for (uint32_t e = L; e; e &= e - 1) {
        const unsigned l = (unsigned)__builtin_ctz(e);
        hi = row[l] > hi ? row[l] : hi;
    }
    return hi;
}

SC_TRAVERSE_INLINE void top_pk_unit_dirs(const top_pk *P, float u[3][16])
{
    for (unsigned l = 0; l < 16; l++) {
        const float inv = 1 / (fabsf(P->d[0][l]) + fabsf(P->d[1][l]) + fabsf(P->d[2][l]));
        for (int k = 0; k < 3; k++)
            u[k][l] = P->d[k][l] * inv;
    }
}
#endif

#ifdef SC_TOP_VP
/* out[i] = the smallest lane of v[i], 16 at once (TV(hmin8) exists for
 * the 8-lane shape SC_TOP_VP is). */
SC_TRAVERSE_INLINE void top_pk_hmin16(const TV(t) v[16], float out[16])
{
    TV(store)(out, TV(hmin8)(v));
    TV(store)(out + 8, TV(hmin8)(v + 8));
}

/* The smallest value of a 16-lane row (negated first if neg) over the
 * lanes of masks m0 (lanes 0-7) and m1 (8-15), in one vector to reduce. */
SC_TRAVERSE_INLINE TV(t) top_pk_halves_min(const float *row, TV(m) m0, TV(m) m1, int neg)
{
    const TV(t) pinf = TV(set1)(INFINITY), zero = TV(set1)(0);
    TV(t) a = TV(load)(row), b = TV(load)(row + 8);
    if (neg)
        a = TV(sub)(zero, a), b = TV(sub)(zero, b);
    return TV(min)(TV(sel)(m0, a, pinf), TV(sel)(m1, b, pinf));
}
#endif

/* The packet's first origin and its spreads: the extents over the lanes of
 * its origins and of its unit-L1 directions, the larger axis of each. */
SC_TRAVERSE_INLINE void top_pk_spread(top_pk *P, uint32_t lanes)
{
    float u[3][16] __attribute__((aligned(64)));
    top_pk_unit_dirs(P, u);
    const unsigned f0 = (unsigned)__builtin_ctz(lanes);
    P->ospread = P->dspread = 0;
#ifdef SC_TOP_VP
    /* the maxima as minima of the negated rows */
    const TV(m) m0 = TV(mask_from_bits)(lanes), m1 = TV(mask_from_bits)(lanes >> 8);
    TV(t) v[16];
    for (int k = 0; k < 3; k++) {
        v[k] = top_pk_halves_min(P->o[k], m0, m1, 0), v[3 + k] = top_pk_halves_min(u[k], m0, m1, 0);
        v[6 + k] = top_pk_halves_min(P->o[k], m0, m1, 1), v[9 + k] = top_pk_halves_min(u[k], m0, m1, 1);
    }
    for (int i = 12; i < 16; i++)
        v[i] = TV(set1)(INFINITY);
    float mins[16] __attribute__((aligned(64)));
    top_pk_hmin16(v, mins);
#endif
    for (int k = 0; k < 3; k++) {
#ifdef SC_TOP_VP
        const float os = -mins[6 + k] - mins[k], ds = -mins[9 + k] - mins[3 + k];
#else
        const float os = top_pk_row_max(P->o[k], lanes) - top_pk_row_min(P->o[k], lanes);
        const float ds = top_pk_row_max(u[k], lanes) - top_pk_row_min(u[k], lanes);
#endif
        P->ospread = os > P->ospread ? os : P->ospread;
        P->dspread = ds > P->dspread ? ds : P->dspread;
        P->o0[k] = P->o[k][f0];
    }
}

/* The largest tcull of the active lanes: the frustum's far bound. */
SC_TRAVERSE_INLINE void top_pk_far(top_pk *P)
{
    P->fr_tmax = top_pk_row_max(P->tcull, P->active);
}

/* Whether every lane of `lanes` is in one octant (P->oct; from P->negm). */
SC_TRAVERSE_INLINE int top_pk_octant(top_pk *P, uint32_t lanes)
{
    P->uniform = 1;
    P->oct = 0;
    for (int k = 0; k < 3; k++) {
        const uint32_t n = P->negm[k] & lanes;
        if (n != 0 && n != lanes)
            P->uniform = 0;
        P->oct |= (n != 0) << k;
    }
    return P->uniform;
}

#ifdef SC_TOP_VP
/* In the ISA's vectors (SC_TOP_VP: a simd_vec.h shape of 8 or 16 lanes)
 * and the frustum in one ymm register: the operations of the portable
 * forms below, in the same order, so the same bits. */

/* sc_top_pre over the lanes (non-parallel rays), and the frustum. */
SC_TRAVERSE_INLINE void top_pk_setup(top_pk *P, uint32_t lanes)
{
    enum { VW = TV(N) };
    const sc_top *T = P->T;
    const TV(t) ga = TV(set1)(T->grow_a), gb = TV(set1)(T->grow_b), xs = TV(set1)(SC_TOP_X_SCALE);
    const TV(t) up = TV(set1)(SC_TOP_M_UP), one = TV(set1)(1.0f), zero = TV(set1)(0.0f);
    const TV(t) c23 = TV(set1)(0x1.0cp-23f), e123 = TV(set1)(0x1p-123f), e124 = TV(set1)(0x1p-124f),
                e122 = TV(set1)(0x1p-122f);
    P->negm[0] = P->negm[1] = P->negm[2] = 0;
    for (unsigned h = 0; h < 16; h += VW) {
        TV(t) o[3], dk[3];
        for (int k = 0; k < 3; k++) {
            o[k] = TV(load)(P->o[k] + h);
            dk[k] = TV(max)(TV(abs)(TV(sub)(TV(set1)(T->lo[k]), o[k])), TV(abs)(TV(sub)(TV(set1)(T->hi[k]), o[k])));
        }
        const TV(t) m = TV(max)(TV(max)(dk[0], dk[1]), dk[2]);
        const TV(t) X = TV(mul)(TV(fmadd)(m, ga, gb), xs);
        for (int k = 0; k < 3; k++) {
            const TV(t) d = TV(load)(P->d[k] + h);
            const TV(t) mk = TV(mul)(TV(add)(dk[k], X), up);
            const TV(t) rd = TV(div)(one, d);
            const TV(t) g = TV(fmadd)(TV(abs)(o[k]), c23, TV(fmadd)(mk, c23, e123));
            const TV(t) pad = TV(fmadd)(TV(abs)(rd), g, TV(fmadd)(mk, e124, e122));
            const TV(t) ord = TV(mul)(o[k], rd);
            TV(store)(P->rd[k] + h, rd);
            TV(store)(P->ordn[k] + h, TV(add)(ord, pad));
            TV(store)(P->ordf[k] + h, TV(sub)(ord, pad));
            P->negm[k] |= (TV(bits)(TV(lt)(d, zero)) & ((1u << VW) - 1)) << h;
        }
    }
    if (!top_pk_octant(P, lanes))
        return;
    /* the extremes over the traced lanes (the others repeat one of them):
     * the maxima as minima of the negations, 13 reductions at once */
    TV(t) v[16];
    for (int k = 0; k < 3; k++) {
        TV(t) rlo = TV(load)(P->rd[k]), rhi = rlo, on = TV(load)(P->ordn[k]), of = TV(load)(P->ordf[k]);
        for (unsigned h = VW; h < 16; h += VW) {
            const TV(t) r = TV(load)(P->rd[k] + h);
            rlo = TV(min)(rlo, r), rhi = TV(max)(rhi, r);
            on = TV(max)(on, TV(load)(P->ordn[k] + h)), of = TV(min)(of, TV(load)(P->ordf[k] + h));
        }
        v[k] = rlo, v[3 + k] = TV(sub)(zero, rhi), v[6 + k] = TV(sub)(zero, on), v[9 + k] = of;
    }
    TV(t) tm = TV(load)(P->tmin);
    for (unsigned h = VW; h < 16; h += VW)
        tm = TV(min)(tm, TV(load)(P->tmin + h));
    v[12] = tm;
    for (int i = 13; i < 16; i++)
        v[i] = TV(set1)(INFINITY);
    float mins[16] __attribute__((aligned(64)));
    top_pk_hmin16(v, mins);
    for (int k = 0; k < 3; k++) {
        P->fr_rdmin[k] = mins[k], P->fr_rdmax[k] = -mins[3 + k];
        P->fr_onmax[k] = -mins[6 + k], P->fr_ofmin[k] = mins[9 + k];
    }
    P->fr_tmin = mins[12];
}

/* The frustum test of a uniform packet against the node's 8 children (the
 * argument of pk_frustum_node in traverse_bvh8_packet.h: a child that any
 * lane's own test passes passes here); dist: its near bound, below every
 * lane's entry. */
SC_TRAVERSE_INLINE unsigned top_pk_frustum(const top_pk *P, const sc_bvh_node8 *node, float *dist)
{
    f32x8_t tn = f32x8_set1(P->fr_tmin), tf = f32x8_set1(P->fr_tmax);
    for (int k = 0; k < 3; k++) {
        const int neg = P->oct >> k & 1;
        const f32x8_t pn = f32x8_load(node->b[2 * k + neg]), pf = f32x8_load(node->b[2 * k + 1 - neg]);
        const f32x8_t lo = f32x8_set1(P->fr_rdmin[k]), hi = f32x8_set1(P->fr_rdmax[k]), zero = f32x8_set1(0);
        /* a plane below 0 takes the largest rd on the near side, the smallest on the far */
        const f32x8_t rn = f32x8_sel(f32x8_lt(pn, zero), hi, lo), rf = f32x8_sel(f32x8_lt(pf, zero), lo, hi);
        tn = f32x8_max(f32x8_fmsub(pn, rn, f32x8_set1(P->fr_onmax[k])), tn);
        tf = f32x8_min(f32x8_fmsub(pf, rf, f32x8_set1(P->fr_ofmin[k])), tf);
    }
    f32x8_store(dist, tn);
    return f32x8_bits(f32x8_le(tn, tf));
}

/* Child i of a node against the lanes L: the lanes whose own FMA test it
 * passes; *near: the nearest entry among them. */
SC_TRAVERSE_INLINE uint32_t top_pk_child(const top_pk *P, const sc_bvh_node8 *node, int i, uint32_t L, float *near)
{
    enum { VW = TV(N) };
    uint32_t m = 0;
    float dmin = INFINITY;
    for (unsigned h = 0; h < 16; h += VW) {
        if (!((L >> h) & ((1u << VW) - 1)))
            continue;
        TV(t) a = TV(load)(P->tmin + h), b = TV(load)(P->tcull + h);
        for (int k = 0; k < 3; k++) {
            const TV(t) bl = TV(set1)(node->b[2 * k][i]), bh = TV(set1)(node->b[2 * k + 1][i]);
            TV(t) nr = bl, fr = bh;
            if (!P->uniform) {
                const TV(m) ng = TV(mask_from_bits)(P->negm[k] >> h);
                nr = TV(sel)(ng, bh, bl), fr = TV(sel)(ng, bl, bh);
            } else if (P->oct >> k & 1) {
                nr = bh, fr = bl;
            }
            a = TV(max)(TV(fmsub)(nr, TV(load)(P->rd[k] + h), TV(load)(P->ordn[k] + h)), a);
            b = TV(min)(TV(fmsub)(fr, TV(load)(P->rd[k] + h), TV(load)(P->ordf[k] + h)), b);
        }
        const uint32_t hm = TV(bits)(TV(le)(a, b)) & (L >> h) & ((1u << VW) - 1);
        if (hm) {
            m |= hm << h;
            const float d = TV(hmin)(TV(sel)(TV(mask_from_bits)(hm), a, TV(set1)(INFINITY)));
            dmin = d < dmin ? d : dmin;
        }
    }
    *near = dmin;
    return m;
}
#else
SC_TRAVERSE_INLINE void top_pk_setup(top_pk *P, uint32_t lanes)
{
    P->negm[0] = P->negm[1] = P->negm[2] = 0;
    for (unsigned l = 0; l < 16; l++) {
        const sc_ray r = top_pk_ray(P, l, P->tmax[l]);
        sc_ray_pre pre;
        sc_top_pre(P->T, &r, &pre);
        for (int k = 0; k < 3; k++) {
            P->rd[k][l] = pre.rd[k], P->ordn[k][l] = pre.ord_near[k], P->ordf[k][l] = pre.ord_far[k];
            P->negm[k] |= (uint32_t)(P->d[k][l] < 0) << l;
        }
    }
    if (!top_pk_octant(P, lanes))
        return;
    P->fr_tmin = INFINITY;
    for (int k = 0; k < 3; k++)
        P->fr_rdmin[k] = P->fr_ofmin[k] = INFINITY, P->fr_rdmax[k] = P->fr_onmax[k] = -INFINITY;
    for (unsigned l = 0; l < 16; l++) {
        for (int k = 0; k < 3; k++) {
            const float r = P->rd[k][l];
            P->fr_rdmin[k] = r < P->fr_rdmin[k] ? r : P->fr_rdmin[k];
            P->fr_rdmax[k] = r > P->fr_rdmax[k] ? r : P->fr_rdmax[k];
            P->fr_onmax[k] = P->ordn[k][l] > P->fr_onmax[k] ? P->ordn[k][l] : P->fr_onmax[k];
            P->fr_ofmin[k] = P->ordf[k][l] < P->fr_ofmin[k] ? P->ordf[k][l] : P->fr_ofmin[k];
        }
        P->fr_tmin = P->tmin[l] < P->fr_tmin ? P->tmin[l] : P->fr_tmin;
    }
}

SC_TRAVERSE_INLINE unsigned top_pk_frustum(const top_pk *P, const sc_bvh_node8 *node, float *dist)
{
    unsigned mask = 0;
    for (int i = 0; i < SC_BVH_N; i++) {
        float tn = P->fr_tmin, tf = P->fr_tmax;
        for (int k = 0; k < 3; k++) {
            const int neg = P->oct >> k & 1;
            const float pn = node->b[2 * k + neg][i], pf = node->b[2 * k + 1 - neg][i];
            const float rn = pn < 0 ? P->fr_rdmax[k] : P->fr_rdmin[k], rf = pf < 0 ? P->fr_rdmin[k] : P->fr_rdmax[k];
            const float a = fmaf(pn, rn, -P->fr_onmax[k]), b = fmaf(pf, rf, -P->fr_ofmin[k]);
            tn = a > tn ? a : tn;
            tf = b < tf ? b : tf;
        }
        dist[i] = tn;
        mask |= (unsigned)(tn <= tf) << i;
    }
    return mask;
}

SC_TRAVERSE_INLINE uint32_t top_pk_child(const top_pk *P, const sc_bvh_node8 *node, int i, uint32_t L, float *near)
{
    uint32_t m = 0;
    float dmin = INFINITY;
    for (uint32_t e = L; e; e &= e - 1) {
        const unsigned l = (unsigned)__builtin_ctz(e);
        float a = P->tmin[l], b = P->tcull[l];
        for (int k = 0; k < 3; k++) {
            const int neg = P->negm[k] >> l & 1;
            const float nr = node->b[2 * k + neg][i], fr = node->b[2 * k + 1 - neg][i];
            const float tn = fmaf(nr, P->rd[k][l], -P->ordn[k][l]), tf = fmaf(fr, P->rd[k][l], -P->ordf[k][l]);
            a = tn > a ? tn : a;
            b = tf < b ? tf : b;
        }
        if (a <= b) {
            m |= 1u << l;
            dmin = a < dmin ? a : dmin;
        }
    }
    *near = dmin;
    return m;
}
#endif

/* The packet's rows into P (lanes not traced repeat the first traced one),
 * tcull = tmax, each lane's sc_top_ray_extent. Returns the traced lanes
 * parallel to an axis (sc_ray_parallel); *mixed: whether the traced lanes
 * span more than one octant (ray_octant; the parallel ones count as one). */
SC_TRAVERSE_INLINE uint32_t top_pk_load(top_pk *P, uint32_t lanes, const float *rows, int *mixed)
{
    const unsigned W = P->W, f0 = (unsigned)__builtin_ctz(lanes);
#ifdef SC_TOP_VP
    enum { VW = TV(N) };
    if (W >= VW) {
        float *const dst[8] = { P->o[0], P->o[1], P->o[2], P->tmin, P->d[0], P->d[1], P->d[2], P->tmax };
        const TV(t) zero = TV(set1)(0), tiny = TV(set1)(SC_MIN_RCP_INPUT);
        uint32_t par = 0, neg[3] = { 0, 0, 0 };
        for (unsigned h = 0; h < 16; h += VW) {
            const TV(m) m = TV(mask_from_bits)(h < W ? lanes >> h : 0);
            TV(t) v[8];
            for (int k = 0; k < 8; k++) {
                const TV(t) f = TV(set1)(rows[k * W + f0]);
                v[k] = h < W ? TV(sel)(m, TV(load)(rows + k * W + h), f) : f;
                TV(store)(dst[k] + h, v[k]);
            }
            TV(store)(P->tcull + h, v[7]);
            const TV(t) ad[3] = { TV(abs)(v[4]), TV(abs)(v[5]), TV(abs)(v[6]) };
            TV(store)(P->om + h, TV(max)(TV(max)(TV(abs)(v[0]), TV(abs)(v[1])), TV(abs)(v[2])));
            TV(store)(P->dm + h, TV(max)(TV(max)(ad[0], ad[1]), ad[2]));
            /* sc_ray_parallel: not every |d_k| >= SC_MIN_RCP_INPUT (NaN fails) */
            const TV(m) np = TV(and)(TV(and)(TV(ge)(ad[0], tiny), TV(ge)(ad[1], tiny)), TV(ge)(ad[2], tiny));
            par |= (~TV(bits)(np) & ((1u << VW) - 1)) << h;
            for (int k = 0; k < 3; k++)
                neg[k] |= TV(bits)(TV(lt)(v[4 + k], zero)) << h;
        }
        const uint32_t single = lanes & par, np = lanes & ~par;
        *mixed = single && np;
        for (int k = 0; k < 3; k++)
            *mixed |= (neg[k] & np) != 0 && (neg[k] & np) != np;
        return single;
    }
#endif
    for (int l = 0; l < 16; l++) {
        const unsigned src = (unsigned)l < W && (lanes >> l & 1) ? (unsigned)l : f0;
        for (int k = 0; k < 3; k++)
            P->o[k][l] = rows[k * W + src], P->d[k][l] = rows[(4 + k) * W + src];
        P->tmin[l] = rows[3 * W + src], P->tmax[l] = rows[7 * W + src];
        P->tcull[l] = P->tmax[l];
    }
    uint32_t single = 0, octs = 0;
    for (uint32_t e = lanes; e; e &= e - 1) {
        const unsigned l = (unsigned)__builtin_ctz(e);
        const sc_ray r = top_pk_ray(P, l, P->tmax[l]);
        single |= (uint32_t)sc_ray_parallel(&r) << l;
        octs |= 1u << (ray_octant(&r) + 2);   /* -2 (parallel) .. 7 */
        sc_top_ray_extent(&r, &P->om[l], &P->dm[l]);
    }
    *mixed = (octs & (octs - 1)) != 0;
    return single;
}

/* Every lane's best hit a miss at its tmax (sc_top_miss). */
SC_TRAVERSE_INLINE void top_pk_misses(top_pk *P)
{
#ifdef SC_TOP_VP
    const TV(t) zero = TV(set1)(0), miss = TV(set1_bits)(SC_HITREC_MISS), inv = TV(set1_bits)(SC_INVALID_ID);
    for (unsigned h = 0; h < 16; h += TV(N)) {
        TV(store)(P->hit[0] + h, TV(load)(P->tmax + h));
        TV(store)(P->hit[1] + h, zero), TV(store)(P->hit[2] + h, zero);
        TV(store)(P->hit[3] + h, miss);
        TV(store)(P->hit[4] + h, zero), TV(store)(P->hit[5] + h, zero), TV(store)(P->hit[6] + h, zero);
        TV(store)(P->hit[7] + h, inv), TV(store)(P->hit[8] + h, inv);
    }
#else
    for (unsigned l = 0; l < 16; l++) {
        sc_hitrec h;
        sc_top_miss(P->tmax[l], &h);
        sc_hit_lane_put(P->hit, 16, l, &h);
    }
#endif
}

/* The best hits of lanes `lanes` into out (rows of P->W lanes). */
SC_TRAVERSE_INLINE void top_pk_store(const top_pk *P, uint32_t lanes, void *out)
{
    const unsigned W = P->W;
#ifdef SC_TOP_VP
    if (W % TV(N) == 0) {
        for (unsigned r = 0; r < 9; r++)
            for (unsigned h = 0; h < W; h += TV(N))
                TV(store_lanes)((float *)out + r * W + h, lanes >> h, TV(load)(P->hit[r] + h));
        return;
    }
#endif
    for (uint32_t e = lanes; e; e &= e - 1) {
        const unsigned l = (unsigned)__builtin_ctz(e);
        sc_hitrec h;
        sc_hit_lane_get(P->hit, 16, l, &h);
        sc_hit_lane_put(out, W, l, &h);
    }
}

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
    P.T = T, P.W = W, P.any = any, P.st = st;
    P.occluded = any ? out : NULL;
    /* every lane of the rows, traced or not, so that the loops below run
     * over all 16; the lanes not traced repeat the first traced one */
    int inc;   /* lanes in several octants (bounce rays): see below */
    uint32_t single = top_pk_load(&P, lanes, rows, &inc);
    if (any)
        for (uint32_t e = lanes; e; e &= e - 1)
            P.occluded[__builtin_ctz(e)] = 0;
    else
        top_pk_misses(&P);
    uint32_t pl = lanes & ~single;
    if (pl) {
        top_pk_spread(&P, pl);
        if (!top_pk_narrow(&P, T->center, T->half))
            single = lanes, pl = 0;
    }
    /* a packet whose lanes span octants (bounce rays): the object rays of
     * the lanes traced one by one take the one-body kernels, as an
     * incoherent run of single rays does (top_closest) */
    for (uint32_t e = single; e; e &= e - 1) {
        const unsigned l = (unsigned)__builtin_ctz(e);
        const sc_ray r = top_pk_ray(&P, l, P.tmax[l]);
        if (any) {
            P.occluded[l] = st ? top_any(T, &r, st) : top_any_walk(T, &r, inc);
        } else {
            sc_hitrec h;
            sc_top_miss(P.tmax[l], &h);
            if (st)
                top_closest(T, &r, &h, st);
            else
                top_closest_walk(T, &r, &h, inc);
            sc_hit_lane_put(P.hit, 16, l, &h);
        }
    }
    if (!pl)
        goto done;
    if (single) {
        /* the lanes left repeat one of them, for the frustum's extremes */
        const unsigned f = (unsigned)__builtin_ctz(pl);
        for (unsigned l = 0; l < 16; l++)
            if (!(pl >> l & 1)) {
                for (int k = 0; k < 3; k++)
                    P.o[k][l] = P.o[k][f], P.d[k][l] = P.d[k][f];
                P.tmin[l] = P.tmin[f], P.tmax[l] = P.tcull[l] = P.tmax[f];
            }
    }
    P.active = pl;
    top_pk_setup(&P, pl);
    top_pk_far(&P);
    /* any hit: the item that last occluded a ray on this thread is tried
     * first by the lanes that pass its box (its slot in its top node, the
     * walk's own lane test), and skipped by the walk: the other lanes'
     * walks never reach it (top_occ_first) */
    uint64_t skip = SC_TOP_NO_SKIP;
    uint32_t from;
    int found = 0;
    if (any && (skip = top_occ_first(T, &from)) != SC_TOP_NO_SKIP) {
        float near;
        const uint32_t L = top_pk_child(&P, &T->nodes[from >> 3], (int)(from & 7), pl, &near);
        if (st)
            st->nodes++;
        if (L)
            top_pk_visit(&P, (uint32_t)(skip & 0xffffffffu), L);
        found = P.active != pl;
        top_occ_learn(found);
    }
    /* Each node pushes at most its 8 children, as in the single-ray walk,
     * so the single-ray stack bound holds. */
    top_pk_entry stack[SC_TRACE_STACK];
    int sp = 0;
    stack[sp++] = (top_pk_entry){ 0, pl, 0 };
    while (sp && P.active) {
        const top_pk_entry e = stack[--sp];
        const uint32_t L = e.lanes & P.active;
        if (!L)
            continue;
        if (sc_ref_is_leaf(e.ref)) {
            if (any && e.ref == skip)
                continue;
            const uint32_t before = P.active;
            top_pk_visit(&P, (uint32_t)(e.ref & 0xffffffffu), L);
            if (!any) {
                top_pk_far(&P);
            } else if (P.active != before && !found) {
                top_occ_found(T, (uint32_t)(e.ref & 0xffffffffu), e.from, skip != SC_TOP_NO_SKIP);
                found = 1;
            }
            continue;
        }
        const sc_bvh_node8 *node = &T->nodes[e.ref];
        if (st)
            st->nodes++;
        unsigned cand = 0xff;
        float fd[SC_BVH_N] __attribute__((aligned(32)));
        if (P.uniform)
            cand = top_pk_frustum(&P, node, fd);
        uint32_t cl[SC_BVH_N];
        float cd[SC_BVH_N];
        int idx[SC_BVH_N], n = 0;
        for (; cand; cand &= cand - 1) {
            const int i = __builtin_ctz(cand);
            float near;
            if (!node->child[i] || !(cl[i] = top_pk_child(&P, node, i, L, &near)))
                continue;
            cd[i] = P.uniform ? fd[i] : near;
            /* far to near: the nearest is popped first */
            int j = n++;
            while (j > 0 && cd[idx[j - 1]] < cd[i]) {
                idx[j] = idx[j - 1];
                j--;
            }
            idx[j] = i;
        }
        for (int j = 0; j < n; j++)
            stack[sp++] = (top_pk_entry){ node->child[idx[j]], cl[idx[j]], (uint32_t)e.ref << 3 | (uint32_t)idx[j] };
    }
    if (any && !found && skip == SC_TOP_NO_SKIP)
        top_occ_learn(0);
done:
    if (!any)
        top_pk_store(&P, lanes, out);
}

#ifdef SC_TOP_VP
#undef TV
#undef TCAT
#undef TCAT_
#endif

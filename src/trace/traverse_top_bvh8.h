/* The top-level traversal of a two-level scene (trace_top.h), one body for
 * every ISA: included by traverse_bvh8_scalar.c and traverse_bvh8_x86.h
 * after their node test (node_test, ctx_init, trace_ctx) and with
 *   SC_TOP_TABLE   the level's own sc_trace_kernels table, whose
 *                  single-ray kernels trace the items' BVHs.
 * A non-parallel ray takes the level's FMA node test with the instance
 * growth folded into its padding (sc_top_pre, top_ctx_init); a parallel
 * ray the grown boxes of sc_top_slab. A closest-hit ray visits items near
 * first, an any-hit ray from the last slot down; of hits at equal t the smaller
 * (inst, geom, prim) wins, so the answer does not depend on the order. */
#include "trace_top.h"

#ifdef SC_X86_INLINE
/* sc_top_pre with the three axes in one xmm register (lane 3 ignored), as
 * ctx_init_fast does for a BVH's own rays: the same operations, so the
 * same bits, without the stores and reloads of the struct. */
SC_X86_INLINE void top_ctx_init(trace_ctx *c, const sc_top *T, const sc_ray *r)
{
    const __m128 o = _mm_loadu_ps(r->org), d = _mm_loadu_ps(r->dir);
    const __m128 dk = box_reach4(T->lo, T->hi, o);
    /* the largest of lanes 0-2 (max is exact: the order does not matter) */
    const __m128 m01 = _mm_max_ps(dk, _mm_permute_ps(dk, 0x55));
    const float m = _mm_cvtss_f32(_mm_max_ps(m01, _mm_permute_ps(dk, 0xaa)));
    const float X = fmaf(m, T->grow_a, T->grow_b) * SC_TOP_X_SCALE;
    const __m128 mk = _mm_mul_ps(_mm_add_ps(dk, _mm_set1_ps(X)), _mm_set1_ps(SC_TOP_M_UP));
    const __m128 rd = _mm_div_ps(_mm_set1_ps(1.0f), d);
    __m128 ordn, ordf;
    slab_offsets4(o, rd, mk, &ordn, &ordf);
    ctx_set_slab(c, rd, ordn, ordf, r->tmin);
    ctx_set_rows(c, r);
}
#else
static inline void top_ctx_init(trace_ctx *c, const sc_top *T, const sc_ray *r)
{
    sc_ray_pre pre;
    sc_top_pre(T, r, &pre);
    ctx_init(c, &pre);
}
#endif

/* One item against the ray: its hit into *best when better (closest: then
 * returns 1), or 1 if it occludes (any). INC: the world ray is one of many
 * in changing directions, so its object rays take the one-body kernel
 * (closest_incoherent) instead of the octant switch, which such rays
 * mispredict. */
SC_TRAVERSE_INLINE int top_visit(const sc_top *T, uint32_t item, const sc_ray *ray, float om, float dm,
                                 sc_hitrec *best, sc_trace_stats *st, const int ANY, const int INC)
{
    const sc_top_item *it = &T->items[item];
    const sc_bvh *b = *it->bvh;
    if (!b)
        return 0;
    sc_ray r;
    if (it->inv) {
        sc_top_object_ray(it->inv, ray, &r);
        if (!sc_top_surely_valid(it, om, dm) && !sc_ray_valid(&r))
            return 0;
    } else {
        r = *ray;
    }
    const sc_trace_kernels *k = &SC_TOP_TABLE[b->cfg.tri_test];
    if (ANY) {
        if (!st)
            return INC ? k->any_incoherent(b, &r) : k->any(b, &r);
        sc_trace_stats s = { 0 };
        const int occ = k->any_stats(b, &r, &s);
        sc_top_add_counters(st, &s);
        return occ;
    }
    sc_hitrec h;
    r.tmax = sc_top_item_tmax(b, best, ray->tmax);
    if (st) {
        sc_trace_stats s = { 0 };
        k->closest_stats(b, &r, &h, &s);
        sc_top_add_counters(st, &s);
    } else if (INC) {
        k->closest_incoherent(b, &r, &h);
    } else {
        k->closest(b, &r, &h);
    }
    return sc_top_offer(it, b, &h, best);
}

/* The item that last occluded an any-hit ray on this thread is tried
 * first by the next one, before the walk, which then skips it (the
 * "shadow cache" of Haines and Greenberg, 1986): shadow rays from
 * neighbouring pixels towards one light are mostly blocked by the same
 * object, often the one they start on. It is tried only if the ray passes
 * its box (its slot in the top node it hangs from, with the walk's own
 * test): boxes nest exactly and the test is monotone, so the walk would
 * reach it, and the answer is the walk's; only the speed depends on the
 * memory. (Without that test an object walk's float triangle test could
 * report a hit a little outside a triangle for an item the walk culls.)
 * Whether to try it is learnt per thread, as the octant history is: a
 * score, saturating at 0
 * and SC_TOP_OCC_MAX, goes up by 2 when the item occluded the ray (tried,
 * or found by the walk as the occluder) and down by 1 when it did not;
 * from SC_TOP_OCC_ON the item is tried. So it is tried while it blocks
 * about a third of the rays or more: below that a failed try, an instance
 * visit the walk might have culled, costs more than the hits save. Keyed
 * by the top level, whose item count bounds the index (a scene committed
 * again, or another at the same address, is at worst a wrong guess).
 * Thread-local, initial-exec, as the octant history. */
#define SC_TOP_OCC_ON 8
#define SC_TOP_OCC_MAX 15
#define SC_TOP_NO_SKIP (~(uint64_t)0)   /* no top reference is all ones */
static _Thread_local __attribute__((tls_model("initial-exec"))) struct {
    const sc_top *T;
    uint32_t item, from;   /* from: its top node's index << 3 | its slot there */
    int score;
} sc_top_occ;

/* The reference of the item to try first (SC_REF_LEAF | item), or
 * SC_TOP_NO_SKIP when none is to be tried; *from: where it hangs. Top
 * levels of 2^28 items or more (node indices past 29 bits) keep no memory. */
SC_TRAVERSE_INLINE uint64_t top_occ_first(const sc_top *T, uint32_t *from)
{
    *from = sc_top_occ.from;
    return sc_top_occ.T == T && sc_top_occ.item < T->item_count && T->item_count < (1u << 28) &&
                   sc_top_occ.score >= SC_TOP_OCC_ON
               ? SC_REF_LEAF | sc_top_occ.item
               : SC_TOP_NO_SKIP;
}

SC_TRAVERSE_INLINE void top_occ_learn(int blocked)
{
    const int s = sc_top_occ.score + (blocked ? 2 : -1);
    sc_top_occ.score = s < 0 ? 0 : s > SC_TOP_OCC_MAX ? SC_TOP_OCC_MAX : s;
}

/* Item `item` of T, hanging from `from`, occluded a ray; tried: whether
 * the ray tried an item first (and has learnt from it already). */
SC_TRAVERSE_INLINE void top_occ_found(const sc_top *T, uint32_t item, uint32_t from, int tried)
{
    if (!tried)
        top_occ_learn(sc_top_occ.T == T && sc_top_occ.item == item);
    sc_top_occ.T = T, sc_top_occ.item = item, sc_top_occ.from = from;
}

/* The walk keeps the node it is in (a single hit child is entered without
 * a push), and a closest-hit walk keeps how far boxes are tested
 * (sc_top_tmax), recomputed only when an item improves the hit. */
SC_TRAVERSE_INLINE int top_traverse(const sc_top *T, const sc_ray *ray, sc_hitrec *best, sc_trace_stats *st,
                                    const int ANY, const int INC)
{
    const int parallel = sc_ray_parallel(ray);
    trace_ctx ctx;
    /* read only when parallel, set then; GCC cannot see that through the
     * loop (-Wmaybe-uninitialized), and zeroing it costs every ray */
#if defined(__GNUC__) && !defined(__clang__)   /* clang has no such warning */
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wmaybe-uninitialized"
#endif
    sc_top_ray tr;
#if defined(__GNUC__) && !defined(__clang__)
#pragma GCC diagnostic pop
#endif
    if (parallel) {
        double m;
        memset(&ctx, 0, sizeof ctx);   /* not read: the grown-box test below instead */
        sc_top_ray_setup(ray, sc_top_grow(T, ray, &m), &tr);
    } else {
        top_ctx_init(&ctx, T, ray);
    }
    float tcull = ANY ? ray->tmax : sc_top_tmax(best, ray->tmax);
    float om, dm;
    sc_top_ray_extent(ray, &om, &dm);
    sc_stack_entry stack[SC_TRACE_STACK];
    int sp = 0;
    /* any hit: the remembered item, tried (and learnt from) first when its
     * box is passed, then skipped by the walk */
    uint64_t skip = SC_TOP_NO_SKIP;
    uint32_t from = 0;                 /* any hit: where ref hangs from (index << 3 | slot) */
    int tried = 0;
    const uint64_t first = ANY ? top_occ_first(T, &from) : SC_TOP_NO_SKIP;
    if (first != SC_TOP_NO_SKIP) {
        if (st)
            st->nodes++;
        _Alignas(32) float pd[SC_BVH_N];
        const sc_bvh_node8 *parent = &T->nodes[from >> 3];
        const unsigned pm = parallel ? sc_top_slab(&tr, parent, ray->tmin, tcull, pd)
                                     : node_test(&ctx, parent, ray->tmin, tcull, pd, SC_OCT_ANY, 1);
        tried = 1;
        int occ = 0;
        if (pm >> (from & 7) & 1) {
            skip = first;
            occ = top_visit(T, (uint32_t)(first & 0xffffffffu), ray, om, dm, best, st, ANY, INC);
        }
        top_occ_learn(occ);
        if (occ)
            return 1;
    }
    uint64_t ref = 0;                  /* the root, nodes[0] */
    for (;;) {
        if (!sc_ref_is_leaf(ref)) {
            const sc_bvh_node8 *node = &T->nodes[ref];
            if (st)
                st->nodes++;
            _Alignas(32) float dist[SC_BVH_N];
            const unsigned mask = parallel ? sc_top_slab(&tr, node, ray->tmin, tcull, dist)
                                           : node_test(&ctx, node, ray->tmin, tcull, dist, SC_OCT_ANY, 1);
            if (mask) {
                const uint32_t at = (uint32_t)ref << 3;
                if ((mask & (mask - 1)) == 0) {
                    ref = node->child[__builtin_ctz(mask)];
                    from = at | (uint32_t)__builtin_ctz(mask);
                } else if (ANY) {
                    /* no distance order for any hit, but not the BVHs'
                     * slot order either: from the last slot down (the
                     * others pushed upward, so they pop downward). In
                     * slot order (push_children) shadow rays through
                     * 1,000 instances ran 5 % slower and their packets
                     * 7 % (docs/scenes.md, twenty-fourth session). */
                    const unsigned last = 31 - (unsigned)__builtin_clz(mask);
                    ref = node->child[last];
                    from = at | last;
                    for (unsigned m = mask & ~(1u << last); m; m &= m - 1) {
                        stack[sp].ref = node->child[__builtin_ctz(m)];
                        stack[sp].from = at | (uint32_t)__builtin_ctz(m);
                        sp++;
                    }
                } else {
                    ref = push_children(node, mask, dist, stack, &sp, 0, SC_OCT_ANY);
                }
                continue;
            }
        } else if ((!ANY || ref != skip) && top_visit(T, (uint32_t)(ref & 0xffffffffu), ray, om, dm, best, st, ANY, INC)) {
            if (ANY) {
                top_occ_found(T, (uint32_t)(ref & 0xffffffffu), from, tried);
                return 1;
            }
            tcull = sc_top_tmax(best, ray->tmax);
        }
        do {
            if (sp == 0) {
                if (ANY && !tried)
                    top_occ_learn(0);
                return 0;
            }
            sp--;
        } while (!ANY && stack[sp].dist > tcull);
        ref = stack[sp].ref;
        if (ANY)
            from = stack[sp].from;
    }
}

/* The walks without statistics, inc as INC above: one copy each for
 * top_closest and the lanes top_packet sends one by one. */
static SC_TARGET __attribute__((noinline)) void top_closest_walk(const sc_top *T, const sc_ray *ray, sc_hitrec *hit,
                                                                 int inc)
{
    if (inc)
        top_traverse(T, ray, hit, NULL, 0, 1);
    else
        top_traverse(T, ray, hit, NULL, 0, 0);
}

static SC_TARGET __attribute__((noinline)) int top_any_walk(const sc_top *T, const sc_ray *ray, int inc)
{
    return inc ? top_traverse(T, ray, NULL, NULL, 1, 1) : top_traverse(T, ray, NULL, NULL, 1, 0);
}

/* *hit: a miss (t = tmax) on entry, the closest hit on return. Which
 * kernel the object rays take is learnt from the world rays before this
 * one on the thread, as sc_trace_closest learns it (traverse_adaptive's
 * history, here of world rays: an object ray's octant also turns with
 * its instance, so its own history says little). Any-hit rays keep the
 * octant switch, as sc_trace_any does. */
static SC_TARGET void top_closest(const sc_top *T, const sc_ray *ray, sc_hitrec *hit, sc_trace_stats *st)
{
    if (st)
        top_traverse(T, ray, hit, st, 0, 0);
    else
        top_closest_walk(T, ray, hit, oct_history_incoherent(ray_octant(ray)));
}

static SC_TARGET int top_any(const sc_top *T, const sc_ray *ray, sc_trace_stats *st)
{
    return st ? top_traverse(T, ray, NULL, st, 1, 0) : top_any_walk(T, ray, 0);
}

/* The top-level traversal of a two-level scene (trace_top.h), one body for
 * every ISA: included by traverse_bvh8_scalar.c and traverse_bvh8_x86.h
 * after their node test (node_test, ctx_init, trace_ctx) and with
 *   SC_TOP_TABLE   the level's own sc_trace_kernels table, whose
 *                  single-ray kernels trace the items' BVHs.
 * A non-parallel ray takes the level's FMA node test with the instance
 * growth folded into its padding (sc_top_pre); a parallel ray the grown
 * boxes of sc_top_slab. Items are visited near first; of hits at equal t
 * the smaller (inst, geom, prim) wins, so the answer does not depend on the
 * order. */
#include "trace_top.h"

/* One item against the ray: its hit into *best when better (closest), or
 * 1 if it occludes (any). */
SC_TRAVERSE_INLINE int top_visit(const sc_top *T, uint32_t item, const sc_ray *ray, sc_hitrec *best,
                                 sc_trace_stats *st, const int ANY)
{
    const sc_top_item *it = &T->items[item];
    const sc_bvh *b = *it->bvh;
    if (!b)
        return 0;
    sc_ray r = *ray;
    if (it->inv) {
        sc_top_object_ray(it->inv, ray, &r);
        if (!sc_ray_valid(&r))
            return 0;
    }
    const sc_trace_kernels *k = &SC_TOP_TABLE[b->cfg.tri_test];
    sc_trace_stats s = { 0 };
    int occ = 0;
    sc_hitrec h;
    if (ANY) {
        occ = st ? k->any_stats(b, &r, &s) : k->any(b, &r);
    } else {
        r.tmax = sc_top_item_tmax(b, best, ray->tmax);
        if (st)
            k->closest_stats(b, &r, &h, &s);
        else
            k->closest(b, &r, &h);
    }
    /* the item's counters, but not its ray: the caller counts the world ray once */
    if (st)
        st->nodes += s.nodes, st->leaves += s.leaves, st->sphere_tests += s.sphere_tests,
            st->sphere_rejects += s.sphere_rejects, st->tri_tests += s.tri_tests, st->tri_hits += s.tri_hits;
    if (ANY)
        return occ;
    sc_top_map_ids(b, &h);
    if (h.prim != SC_HITREC_MISS)
        h.inst = it->inst;
    if (sc_top_better(&h, best)) {
        if (it->inv)
            sc_top_normal(it->cof, h.ng);
        *best = h;
    }
    return 0;
}

SC_TRAVERSE_INLINE int top_traverse(const sc_top *T, const sc_ray *ray, sc_hitrec *best, sc_trace_stats *st,
                                    const int ANY)
{
    double m;
    const double E = sc_top_grow(T, ray, &m);
    const int parallel = sc_ray_parallel(ray);
    trace_ctx ctx;
    sc_top_ray tr;
    sc_ray_pre pre;
    sc_top_pre(T, ray, E, &pre);
    ctx_init(&ctx, &pre);
    if (parallel)
        sc_top_ray_setup(ray, E, &tr);
    sc_stack_entry stack[SC_TRACE_STACK];
    int sp = 0;
    stack[sp].ref = 0;
    stack[sp].dist = ray->tmin;
    sp++;
    while (sp) {
        const sc_stack_entry e = stack[--sp];
        const float tmax = ANY ? ray->tmax : sc_top_tmax(best, ray->tmax);
        if (e.dist > tmax)
            continue;
        if (sc_ref_is_leaf(e.ref)) {
            if (top_visit(T, (uint32_t)(e.ref & 0xffffffffu), ray, best, st, ANY))
                return 1;
            continue;
        }
        const sc_bvh_node8 *node = &T->nodes[e.ref];
        if (st)
            st->nodes++;
        _Alignas(32) float dist[SC_BVH_N];
        const unsigned mask = parallel ? sc_top_slab(&tr, node, ray->tmin, tmax, dist)
                                       : node_test(&ctx, node, ray->tmin, tmax, dist, SC_OCT_ANY, 1);
        if (!mask)
            continue;
        if ((mask & (mask - 1)) == 0) {
            const int i = __builtin_ctz(mask);
            stack[sp].ref = node->child[i];
            stack[sp].dist = dist[i];
            sp++;
            continue;
        }
        const uint64_t nearest = sc_order_children(node, mask, dist, stack, &sp);
        int i = 0;
        while (node->child[i] != nearest)
            i++;
        stack[sp].ref = nearest;
        stack[sp].dist = dist[i];
        sp++;
    }
    return 0;
}

/* *hit: a miss (t = tmax) on entry, the closest hit on return. */
static SC_TARGET void top_closest(const sc_top *T, const sc_ray *ray, sc_hitrec *hit, sc_trace_stats *st)
{
    if (st)
        top_traverse(T, ray, hit, st, 0);
    else
        top_traverse(T, ray, hit, NULL, 0);
}

static SC_TARGET int top_any(const sc_top *T, const sc_ray *ray, sc_trace_stats *st)
{
    return st ? top_traverse(T, ray, NULL, st, 1) : top_traverse(T, ray, NULL, NULL, 1);
}

/* The single-ray traversal of the 8-wide BVH, one body for every ISA. The
 * translation unit that includes it (traverse_bvh8_scalar.c,
 * traverse_bvh8_x86.h) first defines, for its ISA:
 *   SC_TARGET        the function attribute (target ISA; empty for scalar)
 *   trace_ctx        per-ray state, filled by ctx_init (any ray) or
 *                    ctx_init_fast (a non-parallel ray), and ctx_set_rows
 *                    (its near and far rows when the octant is not a
 *                    compile-time constant)
 *   node_test        8 child boxes -> hit mask + entry distances;
 *                    node_test_par the same for parallel rays
 *   sphere_reject    one ray against a leaf's sphere block (its own ISA's
 *                    kernel, inlined: no dispatch inside the traversal)
 *   summary_reject   the same against a leaf's compact summary
 *   leaf_test        one leaf block -> hit mask + t, barycentric numerators,
 *                    denominators; for SC_TRI_EXACT the mask of lanes left
 *                    to sc_exact_resolve and per lane the float t's error bound
 * and gets the kernels closest_<test>, any_<test>, closest_stats_<test> and
 * any_stats_<test> for every sc_tri_test, gathered by SC_TRACE_KERNEL_TABLE.
 *
 * One body serves closest/any and with/without statistics: the flags are
 * compile-time constants of always-inlined code, so the statistics-free
 * kernels contain no counting at all.
 */
#include "bvh/bvh_internal.h"
#include "trace_kernels.h"
#include "traverse_stack.h"
#include "tri_exact.h"

/* the near-first order of hit children: a level may bring its own */
#ifndef SC_ORDER_CHILDREN
#define SC_ORDER_CHILDREN sc_order_children
#endif
#define SC_TRAVERSE_INLINE static inline __attribute__((always_inline)) SC_TARGET

/* The first four cache lines of what a child reference points at: a
 * node's boxes and references, or a leaf's spheres and first rows. */
SC_TRAVERSE_INLINE void sc_prefetch_at(const char *nodes, const unsigned char *leaves, uint64_t ref)
{
    const char *p = sc_ref_is_leaf(ref) ? (const char *)sc_leaf_block(leaves, ref) : nodes + ref;
    __builtin_prefetch(p);
    __builtin_prefetch(p + 64);
    __builtin_prefetch(p + 128);
    __builtin_prefetch(p + 192);
}

SC_TRAVERSE_INLINE void sc_prefetch_ref(const sc_bvh *bvh, uint64_t ref)
{
    sc_prefetch_at((const char *)bvh->nodes, bvh->leaves, ref);
}

/* The closest hit so far of the watertight and Moller tests (the exact
 * test keeps an sc_exact_hit): its id, barycentrics, and the leaf rows and
 * lane it came from, for its normal. t is the traversal's tmax. */
typedef struct sc_best_hit {
    uint32_t prim;
    float u, v;
    const float *rows;
    unsigned W, lane;
} sc_best_hit;

/* One leaf of a traversal: its spheres or summary (when it has them), then
 * its triangles against [tmin, *tmax]; the closest hit goes to *best (or
 * *xb for the exact test) and *tmax shrinks to it. Returns 1 when an
 * any-hit ray has found its hit. cur: the ray, whose tmax this sets for
 * the sphere test. */
SC_TRAVERSE_INLINE int leaf_visit(const sc_bvh *bvh, const trace_ctx *ctx, const sc_ray *ray, sc_ray *cur,
                                  uint64_t ref, float tmin, float *tmaxp, sc_best_hit *best, sc_exact_hit *xbp,
                                  sc_trace_stats *st, const int ANY, const int STATS, const int TEST)
{
    float tmax = *tmaxp;
    const unsigned n = sc_ref_count(ref), W = sc_leaf_width(n);
    const float *block = sc_leaf_block(bvh->leaves, ref);
    const float *rows = sc_leaf_rows(block, W, ref);
    unsigned live = (1u << n) - 1;
    if (STATS)
        st->leaves++;
    if (ref & (SC_REF_SPHERES | SC_REF_SUMMARY)) {
        cur->tmax = tmax;
        uint32_t rej = (sc_ref_has_spheres(ref) ? sphere_reject(cur, block, W) : summary_reject(cur, block, W)) & live;
        if (STATS) {
            st->sphere_tests += n;
            st->sphere_rejects += (uint64_t)__builtin_popcount(rej);
        }
        live &= ~rej;
    }
    if (!live)
        return 0;
    float t[16] __attribute__((aligned(64)));
    float un[16] __attribute__((aligned(64)));
    float vn[16] __attribute__((aligned(64)));
    float den[16] __attribute__((aligned(64)));
    float te[16] __attribute__((aligned(64)));
    if (STATS)
        st->tri_tests += (uint64_t)__builtin_popcount(live);
    unsigned hm = leaf_test(ctx, rows, W, live, tmin, tmax, TEST, t, te, un, vn, den);
    if (TEST == SC_TRI_EXACT) {
        sc_exact_hit *xb = xbp;
        for (; hm; hm &= hm - 1) {
            unsigned i = (unsigned)__builtin_ctz(hm);
            int take;
            float lo, hi;
            if (te[i] >= 0 && sc_exact_fast(ray, t[i], te[i], xb, &take, &lo, &hi)) {
                if (STATS)
                    st->tri_hits++;
                if (ANY)
                    return 1;
                if (take) {
                    xb->have = 1, xb->refined = 0;
                    xb->prim = sc_leaf_prims(rows, W)[i];
                    xb->rows = rows, xb->W = W, xb->lane = i;
                    xb->lo = xb->rlo = lo, xb->hi = xb->rhi = hi;
                    xb->t = t[i], xb->u = un[i] * den[i], xb->v = vn[i] * den[i];
                    tmax = hi;
                }
                continue;
            }
            unsigned nh = sc_exact_resolve(ray, rows, W, 1u << i, t, te, un, vn, den, ANY, xb);
            if (STATS)
                st->tri_hits += nh;
            if (ANY && nh)
                return 1;
            if (!ANY && xb->have)
                tmax = xb->hi;
        }
    } else if (hm) {
        if (STATS)
            st->tri_hits += (uint64_t)__builtin_popcount(hm);
        if (ANY)
            return 1;
        const uint32_t *prims = sc_leaf_prims(rows, W);
        const unsigned bi = sc_nearest_lane(hm, t, prims);
        /* t[bi] <= tmax; of equal t the smaller id, so that the answer
         * does not depend on the order of the leaves (packets visit them
         * in another order) */
        if (t[bi] < tmax || prims[bi] < best->prim) {
            tmax = t[bi];
            best->prim = prims[bi];
            best->u = un[bi] / den[bi];
            best->v = vn[bi] / den[bi];
            best->rows = rows, best->W = W, best->lane = bi;
        }
    }
    *tmaxp = tmax;
    return 0;
}

/* A node's hit children m (two or more): returns the one to visit next and
 * pushes the others. Closest hit: near first. The kernels of one octant
 * (OCT 0..7) serve rays that keep their octant from one ray to the next,
 * camera rays above all, whose neighbours meet the same children in the
 * same order: there the insertion sort's branches predict and a level's
 * sorting network (SC_ORDER_CHILDREN) is only extra work (camera rays 8 %
 * faster without it, median of ten meshes, docs/compare.md, twenty-seventh
 * session). Both give the same order, so the choice changes no answer.
 * Any hit ends the search, so order buys nothing (as in Embree's occlusion
 * traversal): the first in slot order is visited and the rest pushed from
 * the last slot down, so they pop in slot order (the builder puts larger
 * boxes first). */
SC_TRAVERSE_INLINE uint64_t push_children(const sc_bvh_node8 *node, unsigned m, const float *dist,
                                          sc_stack_entry *stack, int *sp, const int ANY, const int OCT)
{
    if (!ANY && OCT >= 0 && OCT < SC_OCT_ANY)
        return sc_order_children(node, m, dist, stack, sp);
    if (!ANY)
        return SC_ORDER_CHILDREN(node, m, dist, stack, sp);
    const uint64_t first = node->child[__builtin_ctz(m)];
    for (m &= m - 1; m; m &= ~(1u << (31 - __builtin_clz(m))))
        stack[(*sp)++].ref = node->child[31 - __builtin_clz(m)];
    return first;
}

/* A closest-hit traversal's answer into *hit (any-hit traversals have
 * nothing to write). */
SC_TRAVERSE_INLINE void traverse_finish(const sc_ray *ray, sc_hitrec *hit, float tmax, const sc_best_hit *best,
                                        sc_exact_hit *xb, const int ANY, const int TEST)
{
    if (TEST == SC_TRI_EXACT && !ANY) {
        sc_exact_finish(ray, xb);
        hit->prim = xb->have ? xb->prim : SC_HITREC_MISS;
        hit->t = xb->have ? xb->t : ray->tmax;
        hit->u = xb->have ? xb->u : 0;
        hit->v = xb->have ? xb->v : 0;
        sc_hit_ids_normal(hit, xb->have ? xb->rows : NULL, xb->W, xb->lane);
    } else if (!ANY) {
        hit->prim = best->prim;
        hit->t = best->prim == SC_HITREC_MISS ? ray->tmax : tmax;
        hit->u = best->u;
        hit->v = best->v;
        sc_hit_ids_normal(hit, best->rows, best->W, best->lane);
    }
}

/* signs: the direction's sign bits when the caller has them (the one-body
 * kernel's rows come from them), or -1 to read them from the ray. */
SC_TRAVERSE_INLINE int
traverse_single_signs(const sc_bvh *bvh, const sc_ray *ray, sc_hitrec *hit, sc_trace_stats *st,
                      const int ANY, const int STATS, const int TEST, const int OCT, const uint64_t root,
                      const int signs)
{
    /* exact mode: tmax is the culling bound, a float >= the exact t of the
     * closest hit so far (xb), which sc_exact_resolve chooses exactly */
    sc_exact_hit xb;
    xb.have = 0;
    trace_ctx ctx;
    int parallel = 0;
    if (OCT >= 0) {
        ctx_init_fast(&ctx, ray, bvh, TEST);
        if (OCT == SC_OCT_ANY && signs >= 0)
            ctx_set_rows_signs(&ctx, (unsigned)signs);
        else if (OCT == SC_OCT_ANY)
            ctx_set_rows(&ctx, ray);
    } else {
        sc_ray_pre p;
        sc_ray_precompute(ray, &p, bvh->root_lo, bvh->root_hi);
        ctx_init(&ctx, &p);
        parallel = p.parallel;
    }
    const float tmin = ray->tmin;
    float tmax = ray->tmax;
    const int prefetch = bvh->prefetch >= (ANY ? SC_PREFETCH_ALL : SC_PREFETCH_CLOSEST);
    sc_ray cur = *ray;
    sc_best_hit best = { SC_HITREC_MISS, 0, 0, NULL, 0, 0 };
    /* Incoherent closest-hit rays in medium-quality trees test the stack's
     * top beside each node (below): random rays about 5 % faster there; in
     * high-quality trees, whose siblings overlap less and are culled more
     * often once a hit is found, 1-5 % slower, and camera rays slower in
     * both (docs/compare.md, forty-second session). */
    /* a constant 0 in every other kernel, where the branch below compiles away */
    const int speculate = OCT == SC_OCT_ANY && !ANY && bvh->quality == SC_BUILD_QUALITY_MEDIUM;
    sc_stack_entry stack[SC_TRACE_STACK_SPECULATE];
    int sp = 0;
    if (STATS)
        st->rays++;
    if (!bvh->has_root)
        goto done;

    /* Locals, not bvh->nodes at each node: the vector stores of the node
     * and leaf tests may alias *bvh, so GCC reloaded bvh and then its
     * nodes before every node's loads, two loads in the way of the next
     * node after each mispredicted branch. */
    const char *const nodes = (const char *)bvh->nodes;
    const unsigned char *const leaves = bvh->leaves;
    uint64_t ref = root;               /* nodes[0], or a subtree (packets hand thin lanes over) */
    for (;;) {
        while (!sc_ref_is_leaf(ref)) {
            const sc_bvh_node8 *node = (const sc_bvh_node8 *)(const void *)(nodes + ref);
            if (STATS)
                st->nodes++;
            float dist[SC_BVH_N] __attribute__((aligned(32)));
            /* OCT = -2: a parallel ray (ray_setup.h); the counting
             * kernels (OCT = -1) decide per ray */
            unsigned m;
            if (speculate && sp > 0 && sp <= SC_TRACE_STACK - SC_BVH_N && !sc_ref_is_leaf(stack[sp - 1].ref) &&
                stack[sp - 1].dist <= tmax) {
                /* The stack's top is visited after this node's subtree,
                 * whatever that finds: its test runs now, beside this
                 * node's, where the two chains of loads overlap, and its
                 * hit children take its place (nearest on top, as its pop
                 * would leave them). Tested with the tmax of now, it may keep
                 * children that a later test would not; each is pushed
                 * with its own entry distance, which the pop compares with
                 * the tmax of then, so exactly the nodes and leaves of the
                 * plain walk are visited, in the same order. */
                const sc_bvh_node8 *nb = (const sc_bvh_node8 *)(const void *)(nodes + stack[sp - 1].ref);
                float distb[SC_BVH_N] __attribute__((aligned(32)));
                const unsigned mb = node_test(&ctx, nb, tmin, tmax, distb, OCT, 1);
                m = node_test(&ctx, node, tmin, tmax, dist, OCT, 1);
                sp--;
                if (mb) {
                    if (prefetch)
                        for (unsigned h = mb; h; h &= h - 1)
                            sc_prefetch_at(nodes, leaves, nb->child[__builtin_ctz(h)]);
                    unsigned near = (unsigned)__builtin_ctz(mb);
                    for (unsigned h = mb & (mb - 1); h; h &= h - 1)
                        near = distb[__builtin_ctz(h)] < distb[near] ? (unsigned)__builtin_ctz(h) : near;
                    const uint64_t first =
                        (mb & (mb - 1)) == 0 ? nb->child[near] : push_children(nb, mb, distb, stack, &sp, 0, OCT);
                    stack[sp].ref = first, stack[sp].dist = distb[near];
                    sp++;
                }
            } else {
                m = OCT == -2 || (OCT == -1 && parallel) ? node_test_par(&ctx, node, tmin, tmax, dist)
                                                         : node_test(&ctx, node, tmin, tmax, dist, OCT, !ANY);
            }
            if (!m)
                goto pop;
            if ((m & (m - 1)) == 0) {
                ref = node->child[__builtin_ctz(m)];
                /* The one child's lines start loading now, as in Embree: a
                 * node's test loads its box lines at once but its child
                 * references (the fourth line) only after the test, and a
                 * leaf's rows wait for its set-up; in a large tree each
                 * would be a second wait on memory at this level. */
                if (prefetch)
                    sc_prefetch_at(nodes, leaves, ref);
                continue;
            }
            /* In a large tree every hit child's first four cache lines
             * start loading now, as in Embree: the ones pushed are in
             * cache when they are popped, instead of each pop waiting for
             * memory. Most subtrees a blocked shadow ray pushes are never
             * popped: hence any-hit rays prefetch only in the largest trees. */
            if (prefetch)
                for (unsigned h = m; h; h &= h - 1)
                    sc_prefetch_at(nodes, leaves, node->child[__builtin_ctz(h)]);
            ref = push_children(node, m, dist, stack, &sp, ANY, OCT);
        }
        if (leaf_visit(bvh, &ctx, ray, &cur, ref, tmin, &tmax, &best, &xb, st, ANY, STATS, TEST))
            return 1;
    pop:
        do {
            if (sp == 0)
                goto done;
            sp--;
        } while (!ANY && stack[sp].dist > tmax);
        ref = stack[sp].ref;
    }
done:
    traverse_finish(ray, hit, tmax, &best, &xb, ANY, TEST);
    return 0;
}

SC_TRAVERSE_INLINE int
traverse_single(const sc_bvh *bvh, const sc_ray *ray, sc_hitrec *hit, sc_trace_stats *st,
                const int ANY, const int STATS, const int TEST, const int OCT, const uint64_t root)
{
    return traverse_single_signs(bvh, ray, hit, st, ANY, STATS, TEST, OCT, root, -1);
}

/* The statistics-free kernels are specialised per ray octant (the signs of
 * the direction pick the near and far box planes at compile time; -2 is a
 * parallel ray); the counting kernels keep one generic body (-1). */
#ifndef SC_HAVE_RAY_OCTANT     /* a level may bring its own, with these answers */
SC_TRAVERSE_INLINE int ray_octant(const sc_ray *r)
{
    if (sc_ray_parallel(r))
        return -2;
    return (int)sc_ray_signs(r);
}
#endif

/* The kernel of octant oct (ray_octant's). */
SC_TRAVERSE_INLINE int traverse_octant(const sc_bvh *b, const sc_ray *r, sc_hitrec *h, const int ANY, const int TEST,
                                       const uint64_t root, int oct)
{
    switch (oct) {
    case -2: return traverse_single(b, r, h, NULL, ANY, 0, TEST, -2, root);
    case 0: return traverse_single(b, r, h, NULL, ANY, 0, TEST, 0, root);
    case 1: return traverse_single(b, r, h, NULL, ANY, 0, TEST, 1, root);
    case 2: return traverse_single(b, r, h, NULL, ANY, 0, TEST, 2, root);
    case 3: return traverse_single(b, r, h, NULL, ANY, 0, TEST, 3, root);
    case 4: return traverse_single(b, r, h, NULL, ANY, 0, TEST, 4, root);
    case 5: return traverse_single(b, r, h, NULL, ANY, 0, TEST, 5, root);
    case 6: return traverse_single(b, r, h, NULL, ANY, 0, TEST, 6, root);
    default: return traverse_single(b, r, h, NULL, ANY, 0, TEST, 7, root);
    }
}

SC_TRAVERSE_INLINE int traverse_by_octant(const sc_bvh *b, const sc_ray *r, sc_hitrec *h, const int ANY,
                                          const int TEST, const uint64_t root)
{
    return traverse_octant(b, r, h, ANY, TEST, root, ray_octant(r));
}

/* Rays known to be incoherent (the stream calls' one-by-one path, packet
 * lanes that parted ways): one body for every octant. The octant switch
 * above is an indirect jump on the ray's direction signs; for rays in
 * random directions it mispredicts about 7 times in 8, which costs more
 * than the constant rows save (docs/compare.md, seventh session). */
SC_TRAVERSE_INLINE int traverse_incoherent(const sc_bvh *b, const sc_ray *r, sc_hitrec *h, const int ANY,
                                           const int TEST, const uint64_t root)
{
    if (sc_ray_parallel(r))
        return traverse_single(b, r, h, NULL, ANY, 0, TEST, -2, root);
    return traverse_single(b, r, h, NULL, ANY, 0, TEST, SC_OCT_ANY, root);
}

/* A stream's incoherent rays, several at a time (up to SC_INTERLEAVE
 * slots). One ray's traversal is a chain of dependent loads: a node's
 * boxes decide which node is loaded next, and in a tree larger than the
 * caches each of those loads waits for memory while the core has nothing
 * else to do. Here each slot holds one ray's whole traversal state; a step
 * tests one node or one leaf of one slot, starts loading what that slot
 * visits next, and moves on to the next slot, so the loads of different
 * rays overlap (the software form of what a GPU does with threads;
 * "asynchronous memory access chaining" in the database literature). Every
 * ray takes the same steps as in traverse_incoherent, in the same order,
 * so it gets the same hit bit for bit; only the interleaving of different
 * rays differs.
 *
 * 16 slots: random rays through trees of 13 MB to 440 MB ran 1.30-2.2x
 * their one-by-one speed with 16, 1.20-2.03x with 8, 1.11-1.56x with 4
 * (docs/compare.md, twenty-third session). The slots' stacks share one
 * array of SC_INTERLEAVE_STACK entries sized from the tree's depth (a
 * stack holds at most 7 entries per level above the node being visited),
 * so the whole state stays near 45 KB of the caller's stack (the deepest
 * trees get 4 slots). */
#ifndef SC_INTERLEAVE
#define SC_INTERLEAVE 16
#endif
#define SC_INTERLEAVE_STACK 2048
_Static_assert(SC_INTERLEAVE_STACK / ((SC_BVH_N - 1) * (SC_BVH_MAX_DEPTH + 1) + SC_BVH_N) >= 2,
               "two slots in the deepest tree the builder makes");

typedef struct sc_interleave_slot {
    trace_ctx ctx;
    sc_ray ray, cur;                  /* the ray, and its copy for the sphere test */
    float tmax;
    int sp;
    uint64_t ref;                     /* what the next step visits */
    unsigned idx;                     /* the ray's place in the batch */
    sc_best_hit best;
    sc_exact_hit xb;
    sc_stack_entry *stack;            /* its part of the shared array */
} sc_interleave_slot;

/* One node or leaf of slot q's traversal. 0: more to do (q->ref is
 * loading); 1: done; 2: an any-hit ray found its hit. */
SC_TRAVERSE_INLINE int interleave_step(const sc_bvh *bvh, sc_interleave_slot *q, const int ANY, const int TEST)
{
    const uint64_t ref = q->ref;
    if (!sc_ref_is_leaf(ref)) {
        const sc_bvh_node8 *node = (const sc_bvh_node8 *)(const void *)((const char *)bvh->nodes + ref);
        float dist[SC_BVH_N] __attribute__((aligned(32)));
        unsigned m = node_test(&q->ctx, node, q->ray.tmin, q->tmax, dist, SC_OCT_ANY, !ANY);
        if (m) {
            q->ref = (m & (m - 1)) == 0 ? node->child[__builtin_ctz(m)]
                                        : push_children(node, m, dist, q->stack, &q->sp, ANY, SC_OCT_ANY);
            sc_prefetch_ref(bvh, q->ref);
            return 0;
        }
    } else if (leaf_visit(bvh, &q->ctx, &q->ray, &q->cur, ref, q->ray.tmin, &q->tmax, &q->best, &q->xb, NULL, ANY,
                          0, TEST)) {
        return 2;
    }
    /* traverse_single's pop, written out in both: as a shared helper it
     * made GCC compile the single-ray closest-hit loop differently (2.4 KB
     * larger), where push_children leaves it instruction for instruction
     * as it was */
    do {
        if (q->sp == 0)
            return 1;
        q->sp--;
    } while (!ANY && q->stack[q->sp].dist > q->tmax);
    q->ref = q->stack[q->sp].ref;
    sc_prefetch_ref(bvh, q->ref);
    return 0;
}

/* rays[i] (checked rays) -> outs[i] (sc_hitrec, or int32_t for any-hit) */
SC_TRAVERSE_INLINE void traverse_interleaved(const sc_bvh *b, const sc_ray *const *rays, void *const *outs,
                                             unsigned n, const int ANY, const int TEST)
{
    sc_interleave_slot slot[SC_INTERLEAVE];
    sc_stack_entry stacks[SC_INTERLEAVE_STACK];
    /* b->depth counts the inner nodes on the longest path; order_children
     * may store 8 entries past the top */
    const unsigned per = (SC_BVH_N - 1) * ((unsigned)b->depth + 1) + SC_BVH_N;
    const unsigned slots = SC_INTERLEAVE_STACK / per < SC_INTERLEAVE ? SC_INTERLEAVE_STACK / per : SC_INTERLEAVE;
    for (unsigned k = 0; k < slots; k++)
        slot[k].stack = stacks + k * per;
    const unsigned full = (1u << slots) - 1;
    unsigned next = 0, active = 0;
    for (;;) {
        /* the free slots take the next rays; a parallel ray (its own node
         * test) or any ray of an empty tree goes through alone */
        while (next < n && active != full) {
            const sc_ray *r = rays[next];
            if (!b->has_root || sc_ray_parallel(r)) {
                const int o = traverse_single(b, r, outs[next], NULL, ANY, 0, TEST, -2, 0);
                if (ANY)
                    *(int32_t *)outs[next] = o;
                next++;
                continue;
            }
            const unsigned k = (unsigned)__builtin_ctz(~active);
            sc_interleave_slot *q = &slot[k];
            ctx_init_fast(&q->ctx, r, b, TEST);
            ctx_set_rows(&q->ctx, r);
            q->ray = q->cur = *r;
            q->tmax = r->tmax;
            q->sp = 0;
            q->ref = 0;                /* the root, nodes[0] */
            q->idx = next++;
            q->best = (sc_best_hit){ SC_HITREC_MISS, 0, 0, NULL, 0, 0 };
            q->xb.have = 0;
            active |= 1u << k;
        }
        if (!active)
            return;
        for (unsigned m = active; m; m &= m - 1) {
            const unsigned k = (unsigned)__builtin_ctz(m);
            sc_interleave_slot *q = &slot[k];
            const int done = interleave_step(b, q, ANY, TEST);
            if (!done)
                continue;
            if (ANY)
                *(int32_t *)outs[q->idx] = done == 2;
            else
                traverse_finish(&q->ray, outs[q->idx], q->tmax, &q->best, &q->xb, 0, TEST);
            active &= ~(1u << k);
        }
    }
}

/* The public closest-hit call's kernel (sc_trace_closest): which of the
 * two above a ray takes is learnt per thread from the rays before it. A
 * count, saturating at 0 and 15, goes up by one when a ray's octant
 * differs from the last one's and down by one when it does not; at 8 or
 * more (the octant changes more often than not: random and diffuse rays)
 * the ray takes the one body, else the octant switch (camera rays keep
 * their octant from one ray to the next, and the constant rows pay there).
 * The branch on the count is predictable where the switch is not; both
 * give the same bits, so only the speed depends on the history. Any-hit
 * calls, and the object rays of instanced scenes (whose octant changes
 * with each instance's rotation), keep the plain switch: the history cost
 * coherent shadow rays 3-7 % and camera packets through 1,000 instances
 * 4 % (docs/compare.md, twenty-second session). Thread-local, initial-exec:
 * no call to find it from the shared library, no state shared between
 * threads. */
static _Thread_local __attribute__((tls_model("initial-exec"))) struct {
    int oct, score;
} sc_oct_history;

/* The history's update with a ray of octant oct: 1 if the rays have been
 * changing octants (take the one body). */
SC_TRAVERSE_INLINE int oct_history_incoherent(int oct)
{
    int score = sc_oct_history.score + (oct != sc_oct_history.oct ? 1 : -1);
    score = score < 0 ? 0 : score > 15 ? 15 : score;
    sc_oct_history.score = score, sc_oct_history.oct = oct;
    return score >= 8;
}

SC_TRAVERSE_INLINE void traverse_adaptive(const sc_bvh *b, const sc_ray *r, sc_hitrec *h, const int TEST)
{
    const int oct = ray_octant(r);
    if (oct_history_incoherent(oct))
        /* traverse_incoherent, with the parallel test and the signs already
         * taken (from the direction in one register: the rows are known
         * sooner than from three more loads) */
        traverse_single_signs(b, r, h, NULL, 0, 0, TEST, oct == -2 ? -2 : SC_OCT_ANY, 0, oct);
    else
        traverse_octant(b, r, h, 0, TEST, 0, oct);
}

static SC_TARGET void closest_watertight(const sc_bvh *b, const sc_ray *r, sc_hitrec *h)
{
    traverse_by_octant(b, r, h, 0, SC_TRI_WATERTIGHT, 0);
}
static SC_TARGET int any_watertight(const sc_bvh *b, const sc_ray *r)
{
    return traverse_by_octant(b, r, NULL, 1, SC_TRI_WATERTIGHT, 0);
}
static SC_TARGET void closest_incoherent_watertight(const sc_bvh *b, const sc_ray *r, sc_hitrec *h)
{
    traverse_incoherent(b, r, h, 0, SC_TRI_WATERTIGHT, 0);
}
static SC_TARGET void closest_adaptive_watertight(const sc_bvh *b, const sc_ray *r, sc_hitrec *h)
{
    traverse_adaptive(b, r, h, SC_TRI_WATERTIGHT);
}
static SC_TARGET int any_incoherent_watertight(const sc_bvh *b, const sc_ray *r)
{
    return traverse_incoherent(b, r, NULL, 1, SC_TRI_WATERTIGHT, 0);
}
static SC_TARGET void closest_interleaved_watertight(const sc_bvh *b, const sc_ray *const *r, void *const *h,
                                                      unsigned n)
{
    traverse_interleaved(b, r, h, n, 0, SC_TRI_WATERTIGHT);
}
static SC_TARGET void any_interleaved_watertight(const sc_bvh *b, const sc_ray *const *r, void *const *o, unsigned n)
{
    traverse_interleaved(b, r, o, n, 1, SC_TRI_WATERTIGHT);
}
static SC_TARGET void closest_stats_watertight(const sc_bvh *b, const sc_ray *r, sc_hitrec *h, sc_trace_stats *s)
{
    traverse_single(b, r, h, s, 0, 1, SC_TRI_WATERTIGHT, -1, 0);
}
static SC_TARGET int any_stats_watertight(const sc_bvh *b, const sc_ray *r, sc_trace_stats *s)
{
    return traverse_single(b, r, NULL, s, 1, 1, SC_TRI_WATERTIGHT, -1, 0);
}

/* The subtree traversals the packet kernels hand thin lanes to (root: the
 * subtree's reference), out of line: one copy per ISA, not one inlined
 * into every packet kernel. */
static SC_TARGET __attribute__((noinline, unused)) void closest_subtree_watertight(const sc_bvh *b, const sc_ray *r,
                                                                         sc_hitrec *h, uint64_t root)
{
    traverse_incoherent(b, r, h, 0, SC_TRI_WATERTIGHT, root);
}
static SC_TARGET __attribute__((noinline, unused)) int any_subtree_watertight(const sc_bvh *b, const sc_ray *r,
                                                                    uint64_t root)
{
    return traverse_incoherent(b, r, NULL, 1, SC_TRI_WATERTIGHT, root);
}
static SC_TARGET __attribute__((noinline, unused)) int subtree_stats_watertight(const sc_bvh *b, const sc_ray *r,
                                                                      sc_hitrec *h, sc_trace_stats *s,
                                                                      uint64_t root, int any)
{
    return any ? traverse_single(b, r, NULL, s, 1, 1, SC_TRI_WATERTIGHT, -1, root)
               : traverse_single(b, r, h, s, 0, 1, SC_TRI_WATERTIGHT, -1, root);
}

static SC_TARGET void closest_moller(const sc_bvh *b, const sc_ray *r, sc_hitrec *h)
{
    traverse_by_octant(b, r, h, 0, SC_TRI_MOLLER, 0);
}
static SC_TARGET int any_moller(const sc_bvh *b, const sc_ray *r)
{
    return traverse_by_octant(b, r, NULL, 1, SC_TRI_MOLLER, 0);
}
static SC_TARGET void closest_incoherent_moller(const sc_bvh *b, const sc_ray *r, sc_hitrec *h)
{
    traverse_incoherent(b, r, h, 0, SC_TRI_MOLLER, 0);
}
static SC_TARGET void closest_adaptive_moller(const sc_bvh *b, const sc_ray *r, sc_hitrec *h)
{
    traverse_adaptive(b, r, h, SC_TRI_MOLLER);
}
static SC_TARGET int any_incoherent_moller(const sc_bvh *b, const sc_ray *r)
{
    return traverse_incoherent(b, r, NULL, 1, SC_TRI_MOLLER, 0);
}
static SC_TARGET void closest_interleaved_moller(const sc_bvh *b, const sc_ray *const *r, void *const *h,
                                                      unsigned n)
{
    traverse_interleaved(b, r, h, n, 0, SC_TRI_MOLLER);
}
static SC_TARGET void any_interleaved_moller(const sc_bvh *b, const sc_ray *const *r, void *const *o, unsigned n)
{
    traverse_interleaved(b, r, o, n, 1, SC_TRI_MOLLER);
}
static SC_TARGET void closest_stats_moller(const sc_bvh *b, const sc_ray *r, sc_hitrec *h, sc_trace_stats *s)
{
    traverse_single(b, r, h, s, 0, 1, SC_TRI_MOLLER, -1, 0);
}
static SC_TARGET int any_stats_moller(const sc_bvh *b, const sc_ray *r, sc_trace_stats *s)
{
    return traverse_single(b, r, NULL, s, 1, 1, SC_TRI_MOLLER, -1, 0);
}

static SC_TARGET void closest_exact(const sc_bvh *b, const sc_ray *r, sc_hitrec *h)
{
    traverse_by_octant(b, r, h, 0, SC_TRI_EXACT, 0);
}
static SC_TARGET int any_exact(const sc_bvh *b, const sc_ray *r)
{
    return traverse_by_octant(b, r, NULL, 1, SC_TRI_EXACT, 0);
}
static SC_TARGET void closest_incoherent_exact(const sc_bvh *b, const sc_ray *r, sc_hitrec *h)
{
    traverse_incoherent(b, r, h, 0, SC_TRI_EXACT, 0);
}
static SC_TARGET void closest_adaptive_exact(const sc_bvh *b, const sc_ray *r, sc_hitrec *h)
{
    traverse_adaptive(b, r, h, SC_TRI_EXACT);
}
static SC_TARGET int any_incoherent_exact(const sc_bvh *b, const sc_ray *r)
{
    return traverse_incoherent(b, r, NULL, 1, SC_TRI_EXACT, 0);
}
static SC_TARGET void closest_interleaved_exact(const sc_bvh *b, const sc_ray *const *r, void *const *h,
                                                      unsigned n)
{
    traverse_interleaved(b, r, h, n, 0, SC_TRI_EXACT);
}
static SC_TARGET void any_interleaved_exact(const sc_bvh *b, const sc_ray *const *r, void *const *o, unsigned n)
{
    traverse_interleaved(b, r, o, n, 1, SC_TRI_EXACT);
}
static SC_TARGET void closest_stats_exact(const sc_bvh *b, const sc_ray *r, sc_hitrec *h, sc_trace_stats *s)
{
    traverse_single(b, r, h, s, 0, 1, SC_TRI_EXACT, -1, 0);
}
static SC_TARGET int any_stats_exact(const sc_bvh *b, const sc_ray *r, sc_trace_stats *s)
{
    return traverse_single(b, r, NULL, s, 1, 1, SC_TRI_EXACT, -1, 0);
}

/* Initializer of a sc_trace_kernels[SC_TRI_TEST_COUNT] table; a translation
 * unit with packet kernels (watertight only) defines
 * SC_TRACE_PACKETS_WATERTIGHT as their list, with a leading comma. */
#ifndef SC_TRACE_PACKETS_WATERTIGHT
#define SC_TRACE_PACKETS_WATERTIGHT
#endif
/* The top level of two-level scenes on this level's node test and
 * kernels (SC_TOP_TABLE: this level's table). */
#include "traverse_top_bvh8.h"
#include "traverse_top_packet.h"

#define SC_TRACE_TOP                                                                                  \
    , .top_closest = top_closest, .top_any = top_any, .top_packet = top_packet,                       \
    .stream_gather16 = stream_gather16, .packet_valid = packet_valid

#define SC_TRACE_KERNEL_TABLE                                                                         \
    {                                                                                                 \
        [SC_TRI_WATERTIGHT] = { .closest = closest_watertight, .any = any_watertight,                 \
                                .closest_incoherent = closest_incoherent_watertight,                  \
                                .closest_adaptive = closest_adaptive_watertight,                      \
                                .any_incoherent = any_incoherent_watertight,                          \
                                .closest_interleaved = closest_interleaved_watertight,                \
                                .any_interleaved = any_interleaved_watertight,                        \
                                .closest_stats = closest_stats_watertight,                            \
                                .any_stats = any_stats_watertight SC_TRACE_PACKETS_WATERTIGHT SC_TRACE_TOP },      \
        [SC_TRI_MOLLER] = { .closest = closest_moller, .any = any_moller,                             \
                            .closest_incoherent = closest_incoherent_moller,                          \
                            .closest_adaptive = closest_adaptive_moller,                              \
                            .any_incoherent = any_incoherent_moller,                                  \
                            .closest_interleaved = closest_interleaved_moller,                        \
                            .any_interleaved = any_interleaved_moller,                                \
                            .closest_stats = closest_stats_moller, .any_stats = any_stats_moller SC_TRACE_TOP },   \
        [SC_TRI_EXACT] = { .closest = closest_exact, .any = any_exact,                                \
                           .closest_incoherent = closest_incoherent_exact,                            \
                           .closest_adaptive = closest_adaptive_exact,                                \
                           .any_incoherent = any_incoherent_exact,                                    \
                           .closest_interleaved = closest_interleaved_exact,                          \
                           .any_interleaved = any_interleaved_exact,                                  \
                           .closest_stats = closest_stats_exact, .any_stats = any_stats_exact SC_TRACE_TOP },      \
    }

/* The traversal loop, instantiated once per ISA. The including file defines
 *   KFN(name)        suffixes a name with the ISA
 *   KATTR            the function attributes (target ISA)
 *   KCTX             per-ray broadcast state, filled by KFN(ctx_init)
 *   KFN(node_test)   8 child boxes -> hit mask + entry distances
 *   KFN(leaf_test)   one leaf block -> hit mask + t, barycentric numerators, denominators;
 *                    for SC_TRI_EXACT the mask of lanes left to sc_xresolve
 *                    (exact_tri.h) and per lane the float t's error bound
 * and this file makes the kernel table KFN(sc_trace_kernels).
 *
 * One body serves closest/any and with/without statistics: the flags are
 * compile-time constants of always-inlined code, so the statistics-free
 * kernels contain no counting at all.
 */

static inline uint32_t KFN(reject)(const sc_ray *ray, const float *blk, unsigned W)
{
    if (W == 4)
        return sc_reject4(ray, (const sc_sphere_block4 *)(const void *)blk);
    if (W == 8)
        return sc_reject8(ray, (const sc_sphere_block8 *)(const void *)blk);
    return sc_reject16(ray, (const sc_sphere_block16 *)(const void *)blk);
}

/* Pushed children are touched later: start loading their first lines now. */
static inline __attribute__((always_inline)) void KFN(prefetch)(const sc_bvh *bvh, uint64_t ref)
{
    const char *p = sc_ref_is_leaf(ref) ? (const char *)bvh->leaves + sc_ref_offset(ref)
                                        : (const char *)bvh->nodes + ref;
    __builtin_prefetch(p);
    __builtin_prefetch(p + 64);
    __builtin_prefetch(p + 128);
}

static inline __attribute__((always_inline)) KATTR int
KFN(core)(const sc_bvh *bvh, const sc_ray *ray, sc_hitrec *hit, sc_trace_stats *st,
          const int ANY, const int STATS, const int TEST, const int OCT)
{
    /* exact mode: tmax is the culling bound, a float >= the exact t of the
     * closest hit so far (xb), which sc_xresolve chooses exactly */
    sc_xhit xb;
    xb.have = 0;
    KCTX ctx;
    int parallel = 0;
    if (OCT >= 0) {
        KFN(ctx_fast)(&ctx, ray, bvh);
    } else {
        sc_ray_pre p;
        sc_ray_precompute(ray, &p, bvh->root_lo, bvh->root_hi);
        KFN(ctx_init)(&ctx, &p);
        parallel = p.parallel;
    }
    const float tmin = ray->tmin;
    float tmax = ray->tmax;
    sc_ray cur = *ray;
    uint32_t best_prim = SC_HITREC_MISS;
    float best_u = 0, best_v = 0;
    sc_stack_entry stack[SC_TRACE_STACK];
    int sp = 0;
    if (STATS)
        st->rays++;
    if (!bvh->has_root)
        goto done;

    uint64_t ref = 0;                  /* the root, nodes[0] */
    for (;;) {
        while (!sc_ref_is_leaf(ref)) {
            const sc_bvh_node8 *node = (const sc_bvh_node8 *)(const void *)((const char *)bvh->nodes + ref);
            if (STATS)
                st->nodes++;
            float dist[SC_BVH_N] __attribute__((aligned(32)));
            /* OCT = -2: a parallel ray (trace_common.h); the counting
             * kernels (OCT = -1) decide per ray */
            unsigned m = OCT == -2 || (OCT == -1 && parallel)
                             ? KFN(node_test_par)(&ctx, node, tmin, tmax, dist)
                             : KFN(node_test)(&ctx, node, tmin, tmax, dist, OCT, !ANY);
            if (!m)
                goto pop;
            if ((m & (m - 1)) == 0) {
                ref = node->child[__builtin_ctz(m)];
                continue;
            }
            if (ANY) {
                /* Any hit ends the search, so order buys nothing (as in
                 * Embree's occlusion traversal): push all but the first. */
                ref = node->child[__builtin_ctz(m)];
                /* Pushed from the last slot down, so they pop in slot order
                 * (the builder puts larger boxes first). No prefetch: most
                 * pushed subtrees of a blocked shadow ray are never popped. */
                for (m &= m - 1; m; m &= ~(1u << (31 - __builtin_clz(m))))
                    stack[sp++].ref = node->child[31 - __builtin_clz(m)];
                continue;
            }
            ref = sc_order_children(node, m, dist, stack, &sp);
        }
        {
            const unsigned n = sc_ref_count(ref), W = sc_leaf_width(n);
            const float *rows = (const float *)(const void *)(bvh->leaves + sc_ref_offset(ref));
            unsigned live = (1u << n) - 1;
            if (STATS)
                st->leaves++;
            if (sc_ref_has_spheres(ref)) {
                cur.tmax = tmax;
                uint32_t rej = KFN(reject)(&cur, rows, W) & live;
                if (STATS) {
                    st->sphere_tests += n;
                    st->sphere_rejects += (uint64_t)__builtin_popcount(rej);
                }
                live &= ~rej;
                rows += 4 * W;
            }
            if (live) {
                float t[16] __attribute__((aligned(64)));
                float un[16] __attribute__((aligned(64)));
                float vn[16] __attribute__((aligned(64)));
                float den[16] __attribute__((aligned(64)));
                float te[16] __attribute__((aligned(64)));
                if (STATS)
                    st->tri_tests += (uint64_t)__builtin_popcount(live);
                unsigned hm = KFN(leaf_test)(&ctx, rows, W, live, tmin, tmax, TEST, t, te, un, vn, den);
                if (TEST == SC_TRI_EXACT) {
                    for (; hm; hm &= hm - 1) {
                        unsigned i = (unsigned)__builtin_ctz(hm);
                        int take;
                        float lo, hi;
                        if (te[i] >= 0 && sc_xfast(ray, t[i], te[i], &xb, &take, &lo, &hi)) {
                            if (STATS)
                                st->tri_hits++;
                            if (ANY)
                                return 1;
                            if (take) {
                                xb.have = 1, xb.refined = 0;
                                xb.prim = ((const uint32_t *)(const void *)(rows + 9 * W))[i];
                                xb.rows = rows, xb.W = W, xb.lane = i;
                                xb.lo = lo, xb.hi = hi;
                                xb.t = t[i], xb.u = un[i] * den[i], xb.v = vn[i] * den[i];
                                tmax = hi;
                            }
                            continue;
                        }
                        unsigned nh = sc_xresolve(ray, rows, W, 1u << i, t, te, un, vn, den, ANY, &xb);
                        if (STATS)
                            st->tri_hits += nh;
                        if (ANY && nh)
                            return 1;
                        if (!ANY && xb.have)
                            tmax = xb.hi;
                    }
                } else if (hm) {
                    if (STATS)
                        st->tri_hits += (uint64_t)__builtin_popcount(hm);
                    if (ANY)
                        return 1;
                    int bi = __builtin_ctz(hm);
                    for (unsigned rest = hm & (hm - 1); rest; rest &= rest - 1) {
                        int i = __builtin_ctz(rest);
                        if (t[i] < t[bi])
                            bi = i;
                    }
                    tmax = t[bi];
                    best_prim = ((const uint32_t *)(const void *)(rows + 9 * W))[bi];
                    best_u = un[bi] / den[bi];
                    best_v = vn[bi] / den[bi];
                }
            }
        }
    pop:
        do {
            if (sp == 0)
                goto done;
            sp--;
        } while (!ANY && stack[sp].dist > tmax);
        ref = stack[sp].ref;
    }
done:
    if (TEST == SC_TRI_EXACT && !ANY) {
        sc_xhit_finish(ray, &xb);
        hit->prim = xb.have ? xb.prim : SC_HITREC_MISS;
        hit->t = xb.have ? xb.t : ray->tmax;
        hit->u = xb.have ? xb.u : 0;
        hit->v = xb.have ? xb.v : 0;
        return 0;
    }
    if (!ANY) {
        hit->prim = best_prim;
        hit->t = best_prim == SC_HITREC_MISS ? ray->tmax : tmax;
        hit->u = best_u;
        hit->v = best_v;
    }
    return 0;
}

/* The statistics-free kernels are specialised per ray octant (the signs of
 * the direction pick the near and far box planes at compile time); the
 * counting kernels keep one generic body. */
#define SC_OCTANT_SWITCH(CALL)                                                                         \
    if (sc_ray_parallel(r)) {                                                                          \
        CALL(-2);                                                                                      \
    } else                                                                                             \
    switch ((signbit(r->dir[0]) != 0) | (signbit(r->dir[1]) != 0) << 1 | (signbit(r->dir[2]) != 0) << 2) { \
    case 0: CALL(0); break;                                                                            \
    case 1: CALL(1); break;                                                                            \
    case 2: CALL(2); break;                                                                            \
    case 3: CALL(3); break;                                                                            \
    case 4: CALL(4); break;                                                                            \
    case 5: CALL(5); break;                                                                            \
    case 6: CALL(6); break;                                                                            \
    default: CALL(7); break;                                                                           \
    }

#define SC_DEFINE_KERNELS(TEST, TEST_ID)                                                           \
    static KATTR void KFN(closest_##TEST)(const sc_bvh *b, const sc_ray *r, sc_hitrec *h)              \
    {                                                                                                  \
        SC_OCTANT_SWITCH(SC_CALL_CLOSEST_##TEST)                                                       \
    }                                                                                                  \
    static KATTR int KFN(any_##TEST)(const sc_bvh *b, const sc_ray *r)                                 \
    {                                                                                                  \
        int res;                                                                                       \
        SC_OCTANT_SWITCH(SC_CALL_ANY_##TEST)                                                           \
        return res;                                                                                    \
    }                                                                                                  \
    static KATTR void KFN(closest_stats_##TEST)(const sc_bvh *b, const sc_ray *r, sc_hitrec *h,        \
                                                sc_trace_stats *s)                                     \
    {                                                                                                  \
        KFN(core)(b, r, h, s, 0, 1, TEST_ID, -1);                                                  \
    }                                                                                                  \
    static KATTR int KFN(any_stats_##TEST)(const sc_bvh *b, const sc_ray *r, sc_trace_stats *s)        \
    {                                                                                                  \
        return KFN(core)(b, r, NULL, s, 1, 1, TEST_ID, -1);                                        \
    }

#define SC_CALL_CLOSEST_watertight(O) KFN(core)(b, r, h, NULL, 0, 0, SC_TRI_WATERTIGHT, O)
#define SC_CALL_ANY_watertight(O) res = KFN(core)(b, r, NULL, NULL, 1, 0, SC_TRI_WATERTIGHT, O)
#define SC_CALL_CLOSEST_moller(O) KFN(core)(b, r, h, NULL, 0, 0, SC_TRI_MOLLER, O)
#define SC_CALL_ANY_moller(O) res = KFN(core)(b, r, NULL, NULL, 1, 0, SC_TRI_MOLLER, O)
#define SC_CALL_CLOSEST_exact(O) KFN(core)(b, r, h, NULL, 0, 0, SC_TRI_EXACT, O)
#define SC_CALL_ANY_exact(O) res = KFN(core)(b, r, NULL, NULL, 1, 0, SC_TRI_EXACT, O)

SC_DEFINE_KERNELS(watertight, SC_TRI_WATERTIGHT)
SC_DEFINE_KERNELS(moller, SC_TRI_MOLLER)
SC_DEFINE_KERNELS(exact, SC_TRI_EXACT)
#undef SC_DEFINE_KERNELS
#undef SC_OCTANT_SWITCH
#undef SC_CALL_CLOSEST_watertight
#undef SC_CALL_ANY_watertight
#undef SC_CALL_CLOSEST_moller
#undef SC_CALL_ANY_moller
#undef SC_CALL_CLOSEST_exact
#undef SC_CALL_ANY_exact

const sc_trace_kernels KFN(sc_trace_kernels)[SC_TRI_TEST_COUNT] = {
    [SC_TRI_WATERTIGHT] = { KFN(closest_watertight), KFN(any_watertight),
                            KFN(closest_stats_watertight), KFN(any_stats_watertight) },
    [SC_TRI_MOLLER] = { KFN(closest_moller), KFN(any_moller),
                        KFN(closest_stats_moller), KFN(any_stats_moller) },
    [SC_TRI_EXACT] = { KFN(closest_exact), KFN(any_exact),
                       KFN(closest_stats_exact), KFN(any_stats_exact) },
};

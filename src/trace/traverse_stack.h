/* The traversal stack and the near-first order of hit children. */
#ifndef SPHERECULL_TRACE_TRAVERSE_STACK_H
#define SPHERECULL_TRACE_TRAVERSE_STACK_H

#include "bvh/node_bvh8.h"
#include "ray_setup.h"

/* Deepest stack a traversal can need: every level of the binary build tree
 * pushes at most 7 siblings. */
#define SC_TRACE_STACK (SC_BVH_MAX_DEPTH * (SC_BVH_N - 1) + SC_BVH_N)
/* A walk that replaces the stack's top by its hit children before visiting
 * it (traverse_bvh8_single.h) does so only while at most SC_TRACE_STACK - 8
 * entries are held, so it holds at most SC_TRACE_STACK - 1 after; what the
 * walk pushes from there are siblings of its path below the node of then,
 * at most SC_TRACE_STACK more. */
#define SC_TRACE_STACK_SPECULATE (2 * SC_TRACE_STACK)

typedef struct sc_stack_entry {
    uint64_t ref;
    float dist;
    uint32_t from;   /* the top level's any-hit walk: the node the entry is a child of and its slot
                        (index << 3 | slot), for its occluder memory (traverse_top_bvh8.h) */
} sc_stack_entry;
_Static_assert(sizeof(sc_stack_entry) == 16, "two stack entries a 32-byte store, four a 64-byte one");

/* Near-first order: the hit children sorted by entry distance (ties by slot),
 * all but the nearest pushed far-to-near; returns the nearest. The caller
 * passes at least two hit children. */
SC_TRACE_INLINE uint64_t sc_order_children(const sc_bvh_node8 *node, unsigned mask, const float *dist,
                                         sc_stack_entry *stack, int *sp)
{
    /* Two hit children are the most common case (primary and shadow rays
     * alike): one compare, no sort loop and its mispredicted exits. */
    const unsigned rest = mask & (mask - 1);
    if ((rest & (rest - 1)) == 0) {
        int a = __builtin_ctz(mask), b = __builtin_ctz(rest);
        if (dist[b] < dist[a]) {
            int t = a;
            a = b;
            b = t;
        }
        stack[*sp].ref = node->child[b];
        stack[*sp].dist = dist[b];
        (*sp)++;
        return node->child[a];
    }
    uint64_t ref[SC_BVH_N];
    float d[SC_BVH_N];
    int k = 0;
    while (mask) {
        int i = __builtin_ctz(mask);
        mask &= mask - 1;
        float di = dist[i];
        int j = k++;
        while (j > 0 && d[j - 1] > di) {
            d[j] = d[j - 1];
            ref[j] = ref[j - 1];
            j--;
        }
        d[j] = di;
        ref[j] = node->child[i];
    }
    for (int j = k - 1; j > 0; j--) {
        stack[*sp].ref = ref[j];
        stack[*sp].dist = d[j];
        (*sp)++;
    }
    return ref[0];
}

/* The lane of the smallest t among the hit lanes hm (hm != 0); of equal t
 * the smallest primitive id. */
SC_TRACE_INLINE unsigned sc_nearest_lane(unsigned hm, const float *t, const uint32_t *prim)
{
    unsigned bi = (unsigned)__builtin_ctz(hm);
    for (unsigned rest = hm & (hm - 1); rest; rest &= rest - 1) {
        unsigned i = (unsigned)__builtin_ctz(rest);
        if (t[i] < t[bi] || (t[i] == t[bi] && prim[i] < prim[bi]))
            bi = i;
    }
    return bi;
}

#endif

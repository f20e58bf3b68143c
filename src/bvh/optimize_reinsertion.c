/* Reinsertion optimisation of the binary tree (Bittner, Hapala, Havran
 * 2013; in the batched form of Meister and Bittner 2018 that
 * madmann91/bvh's ReinsertionOptimizer also follows): the nodes with the
 * largest boxes are taken out and put back where the sum of the inner
 * nodes' areas falls most. Leaves keep their primitives, so the leaf part
 * of the SAH cost is unchanged and the inner part only falls.
 *
 * Each round finds the best place for every candidate on the tree as the
 * round found it (a pure function of that tree: the rounds' searches could
 * run on threads and give the same answers), then applies them in order of
 * gain, skipping one that touches a node an earlier one changed, one that
 * would hang a subtree below itself, or one that would make the tree deeper
 * than the traversal stacks allow. Everything is ordered by (value, index),
 * so the tree does not depend on anything but the input. */
#include <stdatomic.h>
#include <stdlib.h>
#include <string.h>

#include "build_internal.h"
#include "optimize_reinsertion.h"

#define NONE UINT32_MAX

typedef struct ropt {
    sc_bnode *bn;
    uint32_t *parent;        /* per slot; the root's is NONE */
    uint8_t *height;         /* per slot: levels below it (leaf 0) */
    uint32_t root;
} ropt;

static inline float area_of(const ropt *R, uint32_t i) { return box_area(&R->bn[i].box); }

static inline uint32_t sibling_of(const ropt *R, uint32_t i)
{
    const sc_bnode *p = &R->bn[R->parent[i]];
    return p->a == i ? p->b : p->a;
}

static inline box3 box_union(const box3 *a, const box3 *b)
{
    box3 u = *a;
    box_grow(&u, b);
    return u;
}

/* Boxes and heights from slot i up to the root. */
static void refit_up(ropt *R, uint32_t i)
{
    for (; i != NONE; i = R->parent[i]) {
        sc_bnode *n = &R->bn[i];
        if (n->leaf)
            continue;
        n->box = box_union(&R->bn[n->a].box, &R->bn[n->b].box);
        const uint8_t ha = R->height[n->a], hb = R->height[n->b];
        R->height[i] = (uint8_t)(1 + (ha > hb ? ha : hb));
    }
}

typedef struct move {
    uint32_t from, to;
    float gain;              /* the fall of the inner nodes' area sum */
} move;

typedef struct search_entry {
    float diff;
    uint32_t node;
} search_entry;

/* The best place for node x: the node `to` whose place the new inner node
 * (x, to) takes. Gain of moving x below the parent of `cur`'s sibling
 * subtree: area(P) for the removed parent P, plus what the ancestors between
 * P and the common ancestor shrink without x, minus what the nodes from the
 * sibling down to `to` grow and the new node's area. */
static move find_move(const ropt *R, uint32_t x, search_entry *stack)
{
    move best = { x, NONE, 0 };
    const box3 *xb = &R->bn[x].box;
    const float xa = area_of(R, x);
    const uint32_t P = R->parent[x];
    float diff = area_of(R, P);
    box3 acc = R->bn[sibling_of(R, x)].box;   /* the box of the level's ancestor without x */
    for (uint32_t cur = x;;) {
        const uint32_t s = sibling_of(R, cur), par = R->parent[cur];
        int sp = 0;
        stack[sp++] = (search_entry){ diff, s };
        while (sp) {
            const search_entry e = stack[--sp];
            /* the best this subtree can give is e.diff - xa */
            if (!(e.diff - xa > best.gain))
                continue;
            const box3 u = box_union(&R->bn[e.node].box, xb);
            const float g = e.diff - box_area(&u);
            if (g > best.gain || (g == best.gain && best.to != NONE && e.node < best.to)) {
                best.gain = g;
                best.to = e.node;
            }
            const sc_bnode *n = &R->bn[e.node];
            if (!n->leaf) {
                const float d = g + area_of(R, e.node);
                stack[sp++] = (search_entry){ d, n->b };
                stack[sp++] = (search_entry){ d, n->a };
            }
        }
        if (par == R->root)
            break;
        if (par != P) {
            box_grow(&acc, &R->bn[s].box);
            diff += area_of(R, par) - box_area(&acc);
        }
        cur = par;
    }
    if (best.to == sibling_of(R, x))
        best.to = NONE;
    return best;
}

static int by_gain(const void *pa, const void *pb)
{
    const move *a = pa, *b = pb;
    if (a->gain != b->gain)
        return a->gain > b->gain ? -1 : 1;
    return a->from < b->from ? -1 : a->from > b->from;
}

typedef struct cand {
    float area;
    uint32_t node;
} cand;

/* larger area first, then smaller index */
static inline int cand_before(cand a, cand b) { return a.area > b.area || (a.area == b.area && a.node < b.node); }

/* c[0..k) become the k first of c[0..n) in cand_before order (unordered). */
static void select_first(cand *c, size_t n, size_t k)
{
    size_t lo = 0, hi = n;
    while (hi - lo > 1) {
        const size_t mid = lo + (hi - lo) / 2;
        cand t = c[mid];
        c[mid] = c[hi - 1];
        c[hi - 1] = t;
        const cand pivot = c[hi - 1];
        size_t store = lo;
        for (size_t i = lo; i < hi - 1; i++)
            if (cand_before(c[i], pivot)) {
                t = c[i], c[i] = c[store], c[store] = t;
                store++;
            }
        t = c[store], c[store] = c[hi - 1], c[hi - 1] = t;
        if (store == k || store + 1 == k)
            return;
        if (k < store)
            hi = store;
        else
            lo = store + 1;
    }
}

/* Depth of slot i (root 0), or -1 if x lies on its path to the root. */
static int depth_unless_below(const ropt *R, uint32_t i, uint32_t x)
{
    int d = 0;
    for (; R->parent[i] != NONE; i = R->parent[i], d++)
        if (i == x)
            return -1;
    return i == x ? -1 : d;
}

/* 1 if a is x or one of its ancestors. */
static int on_path_up(const ropt *R, uint32_t x, uint32_t a)
{
    for (; x != NONE; x = R->parent[x])
        if (x == a)
            return 1;
    return 0;
}

/* Moves x below a new inner node in the place of `to`: x's parent P takes
 * its other child's content, whose slot holds `to`'s content, and `to`'s
 * slot becomes the inner node (x, that slot). */
static void apply_move(ropt *R, uint32_t x, uint32_t to)
{
    const uint32_t P = R->parent[x], S = sibling_of(R, x);
    R->bn[P] = R->bn[S];
    R->height[P] = R->height[S];
    if (!R->bn[P].leaf)
        R->parent[R->bn[P].a] = R->parent[R->bn[P].b] = P;
    const uint32_t F = S;
    R->bn[F] = R->bn[to];
    R->height[F] = R->height[to];
    if (!R->bn[F].leaf)
        R->parent[R->bn[F].a] = R->parent[R->bn[F].b] = F;
    R->bn[to].leaf = 0;
    R->bn[to].a = x;
    R->bn[to].b = F;
    R->parent[x] = R->parent[F] = to;
    refit_up(R, to);
    refit_up(R, P);
}

/* The searches of one round on up to `threads` threads: each reads the
 * tree as the round found it and writes only its own moves[i]. */
#define SEARCH_STACK (2 * (size_t)SC_BVH_MAX_DEPTH + 2)

typedef struct search_job {
    const ropt *R;
    const cand *c;
    move *found;
    size_t k;
    atomic_size_t next;
} search_job;

static void *search_work(void *arg)
{
    search_job *j = arg;
    search_entry stack[SEARCH_STACK];
    for (;;) {
        const size_t i = atomic_fetch_add(&j->next, 256);
        if (i >= j->k)
            return NULL;
        const size_t end = i + 256 < j->k ? i + 256 : j->k;
        for (size_t q = i; q < end; q++)
            j->found[q] = find_move(j->R, j->c[q].node, stack);
    }
}

static void search_all(const ropt *R, const cand *c, size_t k, move *found, int threads)
{
    search_job j = { R, c, found, k, 0 };
    atomic_init(&j.next, 0);
    sc_build_run_workers(search_work, &j, threads, k / 256);
}

int sc_reinsertion_optimize(sc_bnode *bn, uint32_t root, size_t slots, const sc_reinsertion_params *p)
{
    if (bn[root].leaf)
        return 0;
    ropt R = { bn, malloc(sizeof(uint32_t) * slots), malloc(slots), root };
    uint32_t *order = malloc(sizeof(uint32_t) * slots);
    cand *c = malloc(sizeof(cand) * slots);
    move *moves = NULL;
    uint8_t *touched = calloc(slots, 1);
    int ok = R.parent && R.height && order && c && touched;
    if (!ok)
        goto out;
    /* parents, and heights bottom-up from a pre-order */
    size_t n = 0;
    R.parent[root] = NONE;
    order[n++] = root;
    for (size_t i = 0; i < n; i++) {
        const sc_bnode *b = &bn[order[i]];
        if (!b->leaf) {
            R.parent[b->a] = R.parent[b->b] = order[i];
            order[n++] = b->a;
            order[n++] = b->b;
        }
    }
    for (size_t i = n; i-- > 0;) {
        const sc_bnode *b = &bn[order[i]];
        uint8_t h = 0;
        if (!b->leaf)
            h = (uint8_t)(1 + (R.height[b->a] > R.height[b->b] ? R.height[b->a] : R.height[b->b]));
        R.height[order[i]] = h;
    }
    /* The set of slots in use does not change (a move reuses P's and S's). */
    size_t k = (size_t)((double)(n - 1) * p->batch_ratio);
    k = k < 1 ? 1 : k > n - 1 ? n - 1 : k;
    moves = malloc(sizeof(move) * k);
    move *found = malloc(sizeof(move) * k);
    if (!moves || !found) {
        free(found);
        ok = 0;
        goto out;
    }
    for (int round = 0; round < p->rounds; round++) {
        size_t m = 0;
        for (size_t i = 0; i < n; i++)
            if (order[i] != root)
                c[m++] = (cand){ area_of(&R, order[i]), order[i] };
        select_first(c, m, k);
        search_all(&R, c, k, found, p->threads);
        size_t nm = 0;
        for (size_t i = 0; i < k; i++)
            if (found[i].to != NONE && found[i].gain > 0)
                moves[nm++] = found[i];
        if (!nm)
            break;
        qsort(moves, nm, sizeof *moves, by_gain);
        memset(touched, 0, slots);
        for (size_t i = 0; i < nm; i++) {
            const uint32_t x = moves[i].from, to = moves[i].to;
            const uint32_t P = R.parent[x], S = sibling_of(&R, x), Pt = R.parent[to];
            if (touched[x] || touched[to] || touched[S] || touched[P] || (Pt != NONE && touched[Pt]))
                continue;
            if (to == S)
                continue;
            /* An earlier move of this round may have put `to` below x or
             * above it; either would tie the tree into a loop. */
            const int dt = depth_unless_below(&R, to, x);
            const int hx = R.height[x], ht = R.height[to];
            if (dt < 0 || on_path_up(&R, x, to) || dt + 1 + (hx > ht ? hx : ht) > SC_BVH_MAX_DEPTH - 1)
                continue;
            touched[x] = touched[to] = touched[S] = touched[P] = 1;
            if (Pt != NONE)
                touched[Pt] = 1;
            apply_move(&R, x, to);
        }
    }
    free(found);
out:
    free(R.parent);
    free(R.height);
    free(order);
    free(c);
    free(moves);
    free(touched);
    return ok ? 0 : -1;
}

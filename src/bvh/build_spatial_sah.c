/* SAH build with spatial splits (SBVH: Stich, Friedrich and Dietrich 2009).
 * Each node weighs the best binned object split against the best spatial
 * split: a plane between bins of equal width over the node's box, on
 * either side of which a primitive that straddles it is cut (by the
 * caller's split function: the builder knows boxes, not triangles), so
 * that a large primitive no longer stretches one child over its sibling.
 * Spatial splits are tried only where the object split's children overlap
 * (by overlap_root of the root's area and overlap_node of the node's) and
 * kept only 1 % below the object split's cost. Duplicates are rationed: a
 * node may add at most its `extra` references, handed down to its
 * children in proportion to their sizes, so the budget is spent all over
 * the tree and not on whichever subtree is built first. A straddling
 * reference goes to one side only when that costs less than cutting it
 * (reference unsplitting). The top levels are built on the calling
 * thread; the subtrees below them, each into its own range of the arrays,
 * on the build's threads. */
#include <float.h>
#include <math.h>
#include <stdatomic.h>
#include <stdlib.h>
#include <string.h>

#include "build_internal.h"
#include "build_spatial_sah.h"
#include "vbox.h"

#define MAX_BINS SC_SAH_MAX_BINS

typedef struct ref {
    box3 box;
    uint32_t id;
} ref;

/* A subtree of fewer than JOB_MAX references below the top levels: built
 * by whichever thread takes it, into its own range of the node and id
 * arrays (room for its references and its whole budget of duplicates). */
#define JOB_MAX SC_SAH_PARALLEL_MIN
typedef struct sp_job {
    ref *r;
    size_t n, extra;
    int owned, depth;
    uint32_t me;             /* its root's slot, in the top levels */
    size_t node_off, id_off, used;
} sp_job;

typedef struct sp_builder {
    const sc_spatial_params *p;
    float root_area;
    uint32_t *ids;
    size_t nids;
    sc_bnode *nodes;
    size_t nnodes;
    /* the top levels (a tree of JOB_MAX references or more): subtrees of
     * fewer are recorded as jobs, and the arrays this walk would free wait
     * until the jobs that read them are done */
    int record;
    sp_job *jobs;
    size_t njobs;
    ref **deferred;
    size_t ndeferred;
} sp_builder;

static void release(sp_builder *S, ref *r, int owned)
{
    if (!owned)
        return;
    if (S->record)
        S->deferred[S->ndeferred++] = r;
    else
        free(r);
}

typedef struct split {
    float cost;
    int axis;
    int bin;                 /* object split: the last bin on the left */
    float pos;               /* spatial split: the plane */
    box3 l, r;
    size_t nl, nr;
} split;

static inline int box_ok(const box3 *b)
{
    return b->lo[0] <= b->hi[0] && b->lo[1] <= b->hi[1] && b->lo[2] <= b->hi[2];
}
static float overlap_area(const box3 *a, const box3 *b)
{
    box3 m;
    for (int k = 0; k < 3; k++) {
        m.lo[k] = a->lo[k] > b->lo[k] ? a->lo[k] : b->lo[k];
        m.hi[k] = a->hi[k] < b->hi[k] ? a->hi[k] : b->hi[k];
        if (!(m.lo[k] < m.hi[k]))
            return 0;
    }
    return box_area(&m);
}

static void range_bounds(const ref *r, size_t n, box3 *bounds, box3 *cb)
{
    vbox b = vbox_empty(), c = vbox_empty();
    for (size_t i = 0; i < n; i++) {
        const vbox p = vbox_load(&r[i].box);
        vbox_grow(&b, p);
        vbox_grow_point(&c, vbox_centre(p));
    }
    *bounds = vbox_box(b);
    *cb = vbox_box(c);
}

static int obj_bin(const ref *r, int axis, float lo, float scale, int nb)
{
    return vbin1(centre_of(&r->box, axis), lo, scale, nb);
}

/* The best split after bin j of one axis's nb bins (into best, if it
 * costs less): enter[k] references start in bin k and leave[k] end in it
 * (both the counts for an object split), the sides' boxes grow over the
 * bins; a side may be neither empty nor everything, and the sides may
 * together hold at most max_dups references more than n. Spatial splits
 * name their plane pos[j + 1]. */
static void sweep(const vbox *bin, const size_t *enter, const size_t *leave, int nb, size_t n, size_t max_dups,
                  int axis, const float *pos, split *best)
{
    vbox rbox[MAX_BINS], acc = vbox_empty();
    size_t rcnt[MAX_BINS], c = 0;
    for (int j = nb - 1; j > 0; j--) {
        vbox_grow(&acc, bin[j]);
        c += leave[j];
        rbox[j] = acc, rcnt[j] = c;
    }
    acc = vbox_empty();
    c = 0;
    for (int j = 0; j < nb - 1; j++) {
        vbox_grow(&acc, bin[j]);
        c += enter[j];
        const size_t cr = rcnt[j + 1];
        if (c == 0 || cr == 0 || c >= n || cr >= n || c + cr - n > max_dups)
            continue;
        const float cost = vbox_area(acc) * leaf_blocks(c) + vbox_area(rbox[j + 1]) * leaf_blocks(cr);
        if (cost < best->cost)
            *best = (split){ cost, axis, j, pos ? pos[j + 1] : 0, vbox_box(acc), vbox_box(rbox[j + 1]), c, cr };
    }
}

/* The best binned object split (centres in nb bins per axis), the three
 * axes binned in one pass. */
static void object_split(const ref *r, size_t n, const box3 *cb, int nb, split *best)
{
    float scale[3];
    for (int axis = 0; axis < 3; axis++) {
        const float ext = cb->hi[axis] - cb->lo[axis];
        scale[axis] = ext > 0 ? (float)nb * (1 - 0x1p-20f) / ext : 0;
    }
    vbox bin[3][MAX_BINS];
    size_t cnt[3][MAX_BINS] = { { 0 } };
    for (int axis = 0; axis < 3; axis++)
        for (int k = 0; k < nb; k++)
            bin[axis][k] = vbox_empty();
    const vpoint vlo = v3(cb->lo), vscale = v3(scale);
    for (size_t i = 0; i < n; i++) {
        const vbox p = vbox_load(&r[i].box);
        int k[4];
        vbin(vbox_centre(p), vlo, vscale, nb, k);
        for (int axis = 0; axis < 3; axis++) {
            vbox_grow(&bin[axis][k[axis]], p);
            cnt[axis][k[axis]]++;
        }
    }
    for (int axis = 0; axis < 3; axis++)
        if (scale[axis] > 0)
            sweep(bin[axis], cnt[axis], cnt[axis], nb, n, 0, axis, NULL, best);
}

/* The bins a coordinate interval [x0, x1] meets, pos[] the nb + 1 planes. */
static void bin_span(const float *pos, float scale, int nb, float x0, float x1, int *first, int *last)
{
    int f = vbin1(x0, pos[0], scale, nb);
    while (f > 0 && x0 < pos[f])
        f--;
    while (f < nb - 1 && x0 >= pos[f + 1])
        f++;
    int l = vbin1(x1, pos[0], scale, nb);
    while (l > f && x1 <= pos[l])
        l--;
    while (l < nb - 1 && x1 > pos[l + 1])
        l++;
    *first = f, *last = l < f ? f : l;
}

/* The best spatial split. Each reference enters the bin that holds its
 * box's low end and leaves from the one that holds its high end; in the
 * bins between, its box is cut to the bin's slab, not its primitive: the
 * cut of the primitive itself (at partition, for the chosen plane only)
 * gives tighter boxes, but the plane this chooses is that of exact cuts
 * in every bin on Sponza and a CAD engine to within 0.2 % of the SAH cost
 * at a quarter of the build time (docs/compare.md). */
static void spatial_split(const ref *r, size_t n, const box3 *bounds, int nb, size_t extra, split *best)
{
    for (int axis = 0; axis < 3; axis++) {
        const float lo = bounds->lo[axis], ext = bounds->hi[axis] - lo;
        if (!(ext > 0))
            continue;
        float pos[MAX_BINS + 1];
        /* no plane at a subnormal coordinate: with denormals-are-zero the
         * cut boxes would end at 0, not at the plane (0 keeps the order) */
        for (int k = 0; k < nb; k++) {
            pos[k] = lo + ext * ((float)k / (float)nb);
            if (k > 0 && fabsf(pos[k]) < FLT_MIN)
                pos[k] = 0;
        }
        pos[nb] = bounds->hi[axis];
        const float scale = (float)nb / ext;
        vbox bin[MAX_BINS];
        size_t in[MAX_BINS] = { 0 }, out[MAX_BINS] = { 0 };
        for (int k = 0; k < nb; k++)
            bin[k] = vbox_empty();
        for (size_t i = 0; i < n; i++) {
            int f, l;
            bin_span(pos, scale, nb, r[i].box.lo[axis], r[i].box.hi[axis], &f, &l);
            if (f == l) {
                vbox_grow(&bin[f], vbox_load(&r[i].box));
            } else {
                for (int b = f; b <= l; b++) {
                    box3 part = r[i].box;
                    if (b > f)
                        part.lo[axis] = pos[b];
                    if (b < l)
                        part.hi[axis] = pos[b + 1];
                    vbox_grow(&bin[b], vbox_load(&part));
                }
            }
            in[f]++, out[l]++;
        }
        sweep(bin, in, out, nb, n, extra, axis, pos, best);
    }
}

static int push(ref **v, size_t *n, size_t *cap, const ref *x)
{
    if (*n == *cap) {
        size_t c = *cap ? 2 * *cap : 16;
        ref *g = realloc(*v, sizeof(ref) * c);
        if (!g)
            return -1;
        *v = g, *cap = c;
    }
    (*v)[(*n)++] = *x;
    return 0;
}

/* The references of r on each side of s's plane, in new arrays: a reference
 * that straddles it is cut, or kept whole on one side where the SAH says
 * that costs less than the cut. -1 when out of memory. */
static int spatial_partition(const sp_builder *S, const ref *r, size_t n, const split *s, ref **L, size_t *nl,
                             ref **R, size_t *nr)
{
    const int a = s->axis;
    const float al = box_area(&s->l), ar = box_area(&s->r);
    const float cnl = (float)s->nl, cnr = (float)s->nr, c_split = al * cnl + ar * cnr;
    size_t capl = s->nl, capr = s->nr;
    *L = malloc(sizeof(ref) * capl), *R = malloc(sizeof(ref) * capr);
    *nl = *nr = 0;
    int bad = !*L || !*R;
    for (size_t i = 0; i < n && !bad; i++) {
        const ref *x = &r[i];
        if (x->box.hi[a] <= s->pos) {
            bad = push(L, nl, &capl, x);
        } else if (x->box.lo[a] >= s->pos) {
            bad = push(R, nr, &capr, x);
        } else {
            box3 ul = s->l, ur = s->r;
            box_grow(&ul, &x->box);
            box_grow(&ur, &x->box);
            const float c_left = box_area(&ul) * cnl + ar * (cnr - 1);
            const float c_right = al * (cnl - 1) + box_area(&ur) * cnr;
            if (c_left < c_split && c_left <= c_right) {
                bad = push(L, nl, &capl, x);
            } else if (c_right < c_split) {
                bad = push(R, nr, &capr, x);
            } else {
                ref pl = { .id = x->id }, pr = { .id = x->id };
                S->p->split(S->p->ctx, x->id, &x->box, a, s->pos, &pl.box, &pr.box);
                const int okl = box_ok(&pl.box), okr = box_ok(&pr.box);
                if (okl || !okr)
                    bad = push(L, nl, &capl, okl ? &pl : x);
                if (okr && !bad)
                    bad = push(R, nr, &capr, &pr);
            }
        }
    }
    if (bad) {
        free(*L), free(*R);
        return -1;
    }
    return 0;
}

static void swap_refs(ref *r, size_t i, size_t j)
{
    ref t = r[i];
    r[i] = r[j];
    r[j] = t;
}

/* Quickselect by centre on axis, ties by id (a primitive appears once in a
 * node, so the order is total and the tree deterministic). */
static void select_median(ref *r, size_t n, size_t mid, int axis)
{
    size_t begin = 0, end = n;
    while (end - begin > 1) {
        swap_refs(r, begin + (end - begin) / 2, end - 1);
        const uint32_t pid = r[end - 1].id;
        const float pc = centre_of(&r[end - 1].box, axis);
        size_t store = begin;
        for (size_t i = begin; i < end - 1; i++) {
            const float c = centre_of(&r[i].box, axis);
            if (c < pc || (c == pc && r[i].id < pid))
                swap_refs(r, i, store++);
        }
        swap_refs(r, store, end - 1);
        if (store == mid)
            return;
        if (mid < store)
            end = store;
        else
            begin = store + 1;
    }
}

/* The subtree over r[0..n) into nodes[me]; frees r if it owns it. */
static void sp_build(sp_builder *S, ref *r, size_t n, int owned, size_t extra, uint32_t me, int depth)
{
    const sc_sah_params *sah = &S->p->sah;
    if (S->record && n < JOB_MAX) {
        S->jobs[S->njobs++] = (sp_job){ .r = r, .n = n, .extra = extra, .owned = owned, .depth = depth, .me = me };
        return;
    }
    box3 bounds, cb;
    range_bounds(r, n, &bounds, &cb);
    sc_bnode *node = &S->nodes[me];
    node->box = bounds;
    split obj = { .cost = INFINITY, .axis = -1 }, sp = { .cost = INFINITY, .axis = -1 };
    if (n > 1 && depth < SC_SAH_MEDIAN_DEPTH) {
        object_split(r, n, &cb, sah->bins, &obj);
        const float ov = obj.axis < 0 ? INFINITY : overlap_area(&obj.l, &obj.r);
        if (extra > 0 && ov >= S->p->overlap_root * S->root_area &&
            ov >= S->p->overlap_node * box_area(&bounds))
            spatial_split(r, n, &bounds, S->p->bins, extra, &sp);
        /* a spatial split must pay for its duplicates: 1 % below the object split */
        if (!(sp.cost < 0.99f * obj.cost))
            sp.cost = INFINITY, sp.axis = -1;
    }
    const float area = box_area(&bounds);
    const float best = obj.cost < sp.cost ? obj.cost : sp.cost;   /* INFINITY: no split found */
    if (n <= 1 || (n <= (size_t)sah->max_leaf && area * leaf_blocks(n) <= sah->traversal_cost * area + best)) {
        node->leaf = 1, node->a = (uint32_t)S->nids, node->b = (uint32_t)n;
        for (size_t i = 0; i < n; i++)
            S->ids[S->nids++] = r[i].id;
        release(S, r, owned);
        return;
    }
    const uint32_t lc = (uint32_t)S->nnodes, rc = lc + 1;
    S->nnodes += 2;
    node->leaf = 0, node->a = lc, node->b = rc;

    if (sp.cost < obj.cost) {
        ref *L, *R;
        size_t nl, nr;
        if (spatial_partition(S, r, n, &sp, &L, &nl, &R, &nr) == 0) {
            if (nl > 0 && nr > 0 && nl < n && nr < n && nl + nr - n <= extra) {
                release(S, r, owned);
                const size_t rem = extra - (nl + nr - n);
                const size_t el = (size_t)((double)rem * (double)nl / (double)(nl + nr));
                sp_build(S, L, nl, 1, el, lc, depth + 1);
                sp_build(S, R, nr, 1, rem - el, rc, depth + 1);
                return;
            }
            free(L), free(R);
        }
        /* out of memory, or the cut went otherwise than the bins said: an object split */
    }
    size_t mid = 0;
    if (obj.axis >= 0) {
        const int a = obj.axis;
        const float scale = (float)sah->bins * (1 - 0x1p-20f) / (cb.hi[a] - cb.lo[a]);
        size_t i = 0, j = n;
        while (i < j) {
            if (obj_bin(&r[i], a, cb.lo[a], scale, sah->bins) <= obj.bin)
                i++;
            else
                swap_refs(r, i, --j);
        }
        mid = i;
    }
    if (mid == 0 || mid == n) {
        /* Deep, or all centres equal: the object median on the widest axis. */
        int axis = 0;
        for (int k = 1; k < 3; k++)
            if (cb.hi[k] - cb.lo[k] > cb.hi[axis] - cb.lo[axis])
                axis = k;
        mid = n / 2;
        select_median(r, n, mid, axis);
    }
    const size_t el = (size_t)((double)extra * (double)mid / (double)n);
    sp_build(S, r, mid, 0, el, lc, depth + 1);
    sp_build(S, r + mid, n - mid, 0, extra - el, rc, depth + 1);
    release(S, r, owned);
}

typedef struct job_queue {
    const sp_builder *top;
    sp_job *jobs;
    size_t njobs;
    atomic_size_t next;
} job_queue;

static void *job_work(void *arg)
{
    job_queue *q = arg;
    for (;;) {
        const size_t k = atomic_fetch_add(&q->next, 1);
        if (k >= q->njobs)
            return NULL;
        sp_job *j = &q->jobs[k];
        sp_builder L = { .p = q->top->p, .root_area = q->top->root_area, .ids = q->top->ids, .nids = j->id_off,
                         .nodes = q->top->nodes, .nnodes = j->node_off };
        sp_build(&L, j->r, j->n, j->owned, j->extra, j->me, j->depth);
        j->used = L.nids - j->id_off;
    }
}

int sc_build_spatial_sah(const box3 *boxes, const uint32_t *ids, size_t n, const sc_spatial_params *p,
                         uint32_t **ids_out, size_t *refs_out, sc_bnode **nodes_out, size_t *node_count)
{
    *ids_out = NULL, *nodes_out = NULL, *refs_out = *node_count = 0;
    const size_t extra = (size_t)((double)p->budget * (double)n), cap = n + extra;
    /* A level of the top holds at most cap / JOB_MAX nodes of JOB_MAX
     * references or more, and there are at most SC_SAH_MEDIAN_DEPTH + 32
     * levels; each such node records at most two jobs. */
    const size_t top_max = (cap / JOB_MAX + 1) * (SC_SAH_MEDIAN_DEPTH + 33);
    sp_builder S = { .p = p, .record = n >= JOB_MAX };
    ref *r = malloc(sizeof(ref) * n);
    S.ids = malloc(sizeof(uint32_t) * cap);
    S.nodes = malloc(sizeof(sc_bnode) * (2 * cap - 1));
    if (S.record) {
        S.jobs = malloc(sizeof(sp_job) * 2 * top_max);
        S.deferred = malloc(sizeof(ref *) * top_max);
    }
    if (!r || !S.ids || !S.nodes || (S.record && (!S.jobs || !S.deferred))) {
        free(r), free(S.ids), free(S.nodes), free(S.jobs), free(S.deferred);
        return -1;
    }
    box3 all;
    box_empty(&all);
    for (size_t i = 0; i < n; i++) {
        r[i] = (ref){ boxes[i], ids[i] };
        box_grow(&all, &boxes[i]);
    }
    S.root_area = box_area(&all);
    S.nnodes = 1;
    sp_build(&S, r, n, 1, extra, 0, 0);
    size_t refs = S.nids;
    if (S.record) {
        /* Each job's range, in the order the top-level walk recorded them:
         * its references and all its budget, its nodes but the root (in
         * its slot above). The ranges and so the tree do not depend on
         * which thread builds which job, nor on how many threads there are. */
        size_t node_off = S.nnodes, id_off = 0;
        for (size_t k = 0; k < S.njobs; k++) {
            sp_job *j = &S.jobs[k];
            j->node_off = node_off, j->id_off = id_off;
            node_off += 2 * (j->n + j->extra) - 2;
            id_off += j->n + j->extra;
        }
        job_queue q = { &S, S.jobs, S.njobs, 0 };
        sc_build_run_workers(job_work, &q, p->sah.threads < 1 ? 1 : p->sah.threads, S.njobs);
        for (size_t k = 0; k < S.njobs; k++)
            refs += S.jobs[k].used;
        for (size_t k = 0; k < S.ndeferred; k++)
            free(S.deferred[k]);
        free(S.jobs), free(S.deferred);
        S.nnodes = node_off;
    }
    *ids_out = S.ids, *refs_out = refs;
    *nodes_out = S.nodes, *node_count = S.nnodes;
    return 0;
}

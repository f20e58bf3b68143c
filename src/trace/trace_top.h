/* The top level of a two-level scene (src/accel, sc_accel.h): what the
 * top-level traversal kernels (traverse_top_bvh8.h, one per ISA) read, and
 * the scalar pieces they share. The scene handle builds it; nothing here
 * knows the handle.
 *
 * Items are the leaves of the top tree: an instance (a BVH reached through
 * a transform) or the scene's own meshes (a BVH without one). A child
 * reference of a top node is SC_REF_LEAF | item index, or an inner node's
 * index.
 *
 * Conservative culling. A world ray reaches an instance as the object
 * space ray rounded once to float, whose points lie within
 * u kappa (|o - T| + t |d|) <= u kappa (2 sqrt(3) m + R) of the world
 * ray's at the same t (kappa >= ||M|| ||M^-1||, m the largest distance of
 * the ray's origin from the top box's planes, R the largest world-box
 * radius around an instance's translation, hits within the top box). E is
 * twice that; node tests widen every box by E, so an instance whose rounded
 * ray hits its geometry is never culled. */
#ifndef SPHERECULL_TRACE_TRACE_TOP_H
#define SPHERECULL_TRACE_TRACE_TOP_H

#include <float.h>
#include <math.h>
#include <stdint.h>
#include <string.h>
#if defined(__SSE2__)
#include <emmintrin.h>
#endif

#include "bvh/bvh_internal.h"
#include "common/sc_round.h"
#include "ray_setup.h"
#include "spherecull/sc_hit.h"

typedef struct sc_top_item {
    const sc_bvh *const *bvh;    /* where the item's BVH is kept (read at trace time); *bvh may be NULL */
    const double *inv;           /* 12: world to object, row-major 3x4; NULL: no transform */
    const float *cof;            /* 9: cof(M), row-major: object normals to world */
    uint32_t inst;               /* hit.inst of its hits (SC_INVALID_ID without a transform) */
    float vo, vdlo, vdhi;        /* its object rays are valid for these world rays (sc_top_valid_bounds) */
    float center[3], half;       /* its world box: centre, half diagonal (packets' coherence test) */
} sc_top_item;

typedef struct sc_top {
    const sc_bvh_node8 *nodes;   /* nodes[0] is the root */
    const sc_top_item *items;
    uint32_t item_count;
    float lo[3], hi[3];          /* the top tree's box */
    float center[3], half;       /* the same box: centre, half diagonal (packets' coherence test) */
    double kappa, radius;
    float grow_a, grow_b;        /* E <= grow_a m + grow_b in float (sc_top_growth_consts) */
} sc_top;

/* A miss of a ray ending at tmax: what the top level starts from. */
static inline void sc_top_miss(float tmax, sc_hitrec *h)
{
    memset(h, 0, sizeof *h);
    h->t = tmax;
    h->prim = SC_HITREC_MISS;
    h->geom = h->inst = SC_INVALID_ID;
}

/* E below from m, the origin's largest distance from the top box's planes. */
static inline double sc_top_growth(const sc_top *T, double m)
{
    return 0x1p-23 * T->kappa * (3.4642 * m + T->radius) * 1.01 + 0x1p-120;
}

/* The float constants of sc_top_growth, rounded up with room for the
 * float rounding of m and of one FMA: fmaf(m_f, a, b) >= sc_top_growth(m)
 * when m_f >= m (1 - u). 2^-118 covers an m a that FTZ flushes (< 2^-126)
 * besides the 2^-120 of the double form. Infinite for absurd kappa: every
 * box is then kept. */
static inline void sc_top_growth_consts(sc_top *T)
{
    const double a = 0x1p-23 * T->kappa * 3.4642 * 1.01 * (1 + 0x1p-20);
    const double b = 0x1p-23 * T->kappa * T->radius * 1.01 * (1 + 0x1p-20) + 0x1p-118;
    T->grow_a = sc_f32_up(a), T->grow_b = sc_f32_up(b);
}

/* The growth of the slab distances on an axis with reciprocal rd: E |rd|, rounded up. */
static inline float sc_top_ek(double E, float rd)
{
    return (float)(E * fabs((double)rd) * (1 + 0x1p-20));
}

/* Row `row` of the world-to-object transform on a point and on a
 * direction, in double, rounded once (the object ray's components). Every
 * level calls these: a form in 256-bit doubles, a column of the inverse a
 * register, measured 2-3 % slower on instanced scenes (docs/scenes.md). */
static inline float sc_top_xfm_point(const double *row, double x, double y, double z)
{
    return (float)(row[0] * x + row[1] * y + row[2] * z + row[3]);
}
static inline float sc_top_xfm_dir(const double *row, double x, double y, double z)
{
    return (float)(row[0] * x + row[1] * y + row[2] * z);
}

/* E of the comment above for ray r; m is returned for the set-up. */
static inline double sc_top_grow(const sc_top *T, const sc_ray *r, double *m_out)
{
    double m = 0;
    for (int k = 0; k < 3; k++) {
        const double dl = fabs((double)T->lo[k] - r->org[k]), dh = fabs((double)T->hi[k] - r->org[k]);
        m = dl > m ? dl : m;
        m = dh > m ? dh : m;
    }
    *m_out = m;
    return sc_top_growth(T, m);
}

/* The object-space ray of an item: M^-1 (o - T), M^-1 d in double, rounded
 * once. With SSE2 each half of it (org, tmin and dir, tmax) is written by
 * one 16-byte store: the kernels load each half as one register
 * (ctx_init_fast), which a load can take from one store in flight but not
 * from several smaller ones (docs/compare.md, forty-first session). */
static inline void sc_top_object_ray(const double *inv, const sc_ray *r, sc_ray *o)
{
    float p[3], d[3];
    for (int i = 0; i < 3; i++) {
        p[i] = sc_top_xfm_point(inv + 4 * i, r->org[0], r->org[1], r->org[2]);
        d[i] = sc_top_xfm_dir(inv + 4 * i, r->dir[0], r->dir[1], r->dir[2]);
    }
#if defined(__SSE2__)
    _mm_storeu_ps((float *)(void *)o, _mm_setr_ps(p[0], p[1], p[2], r->tmin));
    _mm_storeu_ps((float *)(void *)o + 4, _mm_setr_ps(d[0], d[1], d[2], r->tmax));
#else
    *o = (sc_ray){ { p[0], p[1], p[2] }, r->tmin, { d[0], d[1], d[2] }, r->tmax };
#endif
}

/* Bounds under which an item's object ray (sc_top_object_ray) is surely
 * valid (sc_ray_valid), so that the walks need not check it: for a world
 * ray that is valid, with om = max |o_k| <= vo and vdlo <= dm = max |d_k|
 * <= vdhi. With A and B the largest absolute row sums of M^-1 and of its
 * translation column, and F that of M: every object origin component is at
 * most A om + B and every direction component at most A dm before
 * rounding, so both stay below half their limits (SC_MAX_ORIGIN, FLT_MAX);
 * and the largest direction component is at least dm / F exactly, less
 * 2^-51 A dm for the double arithmetic, so it stays at least 2^-124, a
 * normal float that denormals-are-zero does not read as 0. The tmin and
 * tmax are the world ray's. Margins of 2^-20 cover the roundings here; an
 * ill-conditioned or far-translated instance gets bounds no ray meets, and
 * its object rays are checked one by one. */
static inline void sc_top_valid_bounds(const double inv[12], const float xfm[12], float *vo, float *vdlo,
                                       float *vdhi)
{
    double A = 0, B = 0, F = 0;
    for (int i = 0; i < 3; i++) {
        const double a = fabs(inv[4 * i]) + fabs(inv[4 * i + 1]) + fabs(inv[4 * i + 2]);
        const double f = fabs((double)xfm[4 * i]) + fabs((double)xfm[4 * i + 1]) + fabs((double)xfm[4 * i + 2]);
        A = a > A ? a : A;
        F = f > F ? f : F;
        B = fabs(inv[4 * i + 3]) > B ? fabs(inv[4 * i + 3]) : B;
    }
    const double slack = 1 + 0x1p-20;
    *vo = *vdhi = -1;
    *vdlo = INFINITY;
    if (!(A > 0 && F > 0 && isfinite(A) && isfinite(B) && isfinite(F)))
        return;
    const double o = (0.5 * (double)SC_MAX_ORIGIN / slack - B * slack) / (A * slack);
    *vo = o > 0 ? sc_f32_down(o) : -1;
    *vdhi = sc_f32_down(0.5 * (double)FLT_MAX / slack / (A * slack));
    const double g = 1 / (F * slack) - 0x1p-50 * A;
    if (g > 0)
        *vdlo = sc_f32_up(0x1p-124 * slack / g);
}

/* The largest |o_k| and |d_k| of a ray, for sc_top_surely_valid
 * (compares, not fmaxf: a call at the baseline level). */
static inline void sc_top_ray_extent(const sc_ray *r, float *om, float *dm)
{
    float o = fabsf(r->org[0]), d = fabsf(r->dir[0]);
    for (int k = 1; k < 3; k++) {
        const float ok = fabsf(r->org[k]), dk = fabsf(r->dir[k]);
        o = ok > o ? ok : o;
        d = dk > d ? dk : d;
    }
    *om = o, *dm = d;
}

static inline int sc_top_surely_valid(const sc_top_item *it, float om, float dm)
{
    return (om <= it->vo) & (dm <= it->vdhi) & (dm >= it->vdlo);
}

/* A hit of a BVH over several meshes (prim a global id) as (geom, prim). */
static inline void sc_top_map_ids(const sc_bvh *b, sc_hitrec *h)
{
    if (h->prim == SC_HITREC_MISS || b->mesh_count < 2)
        return;
    size_t g = sc_mesh_of(b->first, b->mesh_count, h->prim);
    h->geom = (uint32_t)g;
    h->prim -= b->first[g];
}

/* Of two hits at equal t the smaller (inst, geom, prim) wins; a miss has
 * t = tmax and prim = MISS, so any hit at tmax beats it. */
static inline int sc_top_better(const sc_hitrec *h, const sc_hitrec *best)
{
    if (h->prim == SC_HITREC_MISS)
        return 0;
    if (best->prim == SC_HITREC_MISS || h->t < best->t)
        return 1;
    if (h->t > best->t)
        return 0;
    if (h->inst != best->inst)
        return h->inst < best->inst;
    if (h->geom != best->geom)
        return h->geom < best->geom;
    return h->prim < best->prim;
}

/* How far boxes are tested once best holds a hit: one float past best->t
 * (within the ray's own end), so that a hit of another item at the same
 * rounded t, which may win the tie, is still reached. A hit found past
 * best->t loses to it (sc_top_better). */
static inline float sc_top_tmax_t(float t, float ray_tmax)
{
    /* the next float up, by its bits (t >= tmin >= 0; not libm's
     * nextafterf, a call on every node a ray visits) */
    float up = t;
    if (up >= 0 && up < INFINITY) {
        uint32_t bits;
        memcpy(&bits, &up, sizeof bits);
        bits = up == 0 ? 1 : bits + 1;
        memcpy(&up, &bits, sizeof up);
    }
    return up < ray_tmax ? up : ray_tmax;
}

static inline float sc_top_tmax(const sc_hitrec *best, float ray_tmax)
{
    return best->prim == SC_HITREC_MISS ? ray_tmax : sc_top_tmax_t(best->t, ray_tmax);
}

/* How far an item's BVH is traced. The exact test's reported t is rounded
 * along the path that decided it, and which path that is depends on tmax
 * (a hit near tmax goes to the double stage, whose t is the more accurate
 * one): so an item of that test is traced to the ray's own end, making
 * its answer the same whatever was found before it, and the smallest t
 * over the items does not depend on the order they are visited in. The
 * other tests' t does not depend on tmax, which only filters. Items are
 * still culled by their boxes against sc_top_tmax: a reported t lies
 * within a few ulps of the exact t, which is at least the box's entry,
 * and the culling test's slack (E |1/d| and the relative 2^-21) is far
 * larger than that. */
static inline float sc_top_item_tmax(const sc_bvh *b, const sc_hitrec *best, float ray_tmax)
{
    return b->cfg.tri_test == SC_TRI_EXACT ? ray_tmax : sc_top_tmax(best, ray_tmax);
}

static inline void sc_top_normal(const float *cof, float ng[3])
{
    const float n[3] = { ng[0], ng[1], ng[2] };
    for (int i = 0; i < 3; i++)
        ng[i] = cof[3 * i] * n[0] + cof[3 * i + 1] * n[1] + cof[3 * i + 2] * n[2];
}

/* Hit h of item it's BVH b (its object-space hit) offered to best: its
 * ids mapped, its instance set, and when it wins, its normal taken to
 * world space and the hit kept. Returns 1 if kept. */
static inline int sc_top_offer(const sc_top_item *it, const sc_bvh *b, sc_hitrec *h, sc_hitrec *best)
{
    sc_top_map_ids(b, h);
    if (h->prim != SC_HITREC_MISS)
        h->inst = it->inst;
    if (!sc_top_better(h, best))
        return 0;
    if (it->inv)
        sc_top_normal(it->cof, h->ng);
    *best = *h;
    return 1;
}

/* An item's counters into the caller's, but not its rays: the caller
 * counts each world ray once. */
static inline void sc_top_add_counters(sc_trace_stats *st, const sc_trace_stats *s)
{
    st->nodes += s->nodes, st->leaves += s->leaves, st->sphere_tests += s->sphere_tests;
    st->sphere_rejects += s->sphere_rejects, st->tri_tests += s->tri_tests, st->tri_hits += s->tri_hits;
}

/* The top node test with every box grown by E, in the arithmetic of
 * sc_slab_par (node_bvh8_slab.h; no FMA, so it runs on every level): the
 * single-ray walk takes it for parallel rays (the packet walk sends those
 * lanes to the single-ray walk).
 * (plane - o) * fl(1/d) - Ek, with
 * Ek = E |1/d_k|, carries at most 4u of |plane - o| |1/d| <= (m + E) |1/d|,
 * under a fifth of Ek since E >= 20u m (kappa >= 3 for Frobenius norms);
 * the last rounding is covered by the relative 2^-21 and the absolute
 * 2^-122 at the end. A ray in a slab's plane gives 0 * inf = NaN, which
 * the running max/min ignore (a > b ? a : b returns b for a NaN), and a
 * ray parallel to an axis gets Ek = inf: that axis never culls, which is
 * conservative. dist[i]: a lower bound of child i's entry distance. */
typedef struct sc_top_ray {
    float org[3], rd[3], Ek[3];   /* rd = fl(1/d), +-inf for d = +-0 */
    int near_row[3], far_row[3];
} sc_top_ray;

static inline void sc_top_ray_setup(const sc_ray *r, double E, sc_top_ray *t)
{
    for (int k = 0; k < 3; k++) {
        t->org[k] = r->org[k];
        t->rd[k] = 1.0f / r->dir[k];
        t->Ek[k] = sc_top_ek(E, t->rd[k]);
        const int neg = signbit(r->dir[k]) != 0;
        t->near_row[k] = 2 * k + neg;
        t->far_row[k] = 2 * k + 1 - neg;
    }
}

static inline unsigned sc_top_slab(const sc_top_ray *t, const sc_bvh_node8 *node, float tmin, float tmax,
                                   float *dist)
{
#if defined(__SSE2__)
    /* four children at a time (SSE2, the x86-64 baseline); maxps/minps
     * return their second operand for a NaN */
    __m128 a0 = _mm_set1_ps(tmin), a1 = a0, b0 = _mm_set1_ps(tmax), b1 = b0;
    for (int k = 0; k < 3; k++) {
        const float *nr = node->b[t->near_row[k]], *fr = node->b[t->far_row[k]];
        const __m128 o = _mm_set1_ps(t->org[k]), rd = _mm_set1_ps(t->rd[k]), e = _mm_set1_ps(t->Ek[k]);
        a0 = _mm_max_ps(_mm_sub_ps(_mm_mul_ps(_mm_sub_ps(_mm_load_ps(nr), o), rd), e), a0);
        a1 = _mm_max_ps(_mm_sub_ps(_mm_mul_ps(_mm_sub_ps(_mm_load_ps(nr + 4), o), rd), e), a1);
        b0 = _mm_min_ps(_mm_add_ps(_mm_mul_ps(_mm_sub_ps(_mm_load_ps(fr), o), rd), e), b0);
        b1 = _mm_min_ps(_mm_add_ps(_mm_mul_ps(_mm_sub_ps(_mm_load_ps(fr + 4), o), rd), e), b1);
    }
    const __m128 down = _mm_set1_ps(1.0f - 0x1p-21f), up = _mm_set1_ps(1.0f + 0x1p-21f), eps = _mm_set1_ps(0x1p-122f);
    a0 = _mm_sub_ps(_mm_mul_ps(a0, down), eps);
    a1 = _mm_sub_ps(_mm_mul_ps(a1, down), eps);
    b0 = _mm_add_ps(_mm_mul_ps(b0, up), eps);
    b1 = _mm_add_ps(_mm_mul_ps(b1, up), eps);
    _mm_storeu_ps(dist, a0);
    _mm_storeu_ps(dist + 4, a1);
    return (unsigned)_mm_movemask_ps(_mm_cmple_ps(a0, b0)) | (unsigned)_mm_movemask_ps(_mm_cmple_ps(a1, b1)) << 4;
#else
    float a[SC_BVH_N], b[SC_BVH_N];
    for (int i = 0; i < SC_BVH_N; i++)
        a[i] = tmin, b[i] = tmax;
    for (int k = 0; k < 3; k++) {
        const float *nr = node->b[t->near_row[k]], *fr = node->b[t->far_row[k]];
        const float o = t->org[k], rd = t->rd[k], e = t->Ek[k];
        for (int i = 0; i < SC_BVH_N; i++) {
            const float tn = (nr[i] - o) * rd - e, tf = (fr[i] - o) * rd + e;
            a[i] = tn > a[i] ? tn : a[i];
            b[i] = tf < b[i] ? tf : b[i];
        }
    }
    unsigned mask = 0;
    for (int i = 0; i < SC_BVH_N; i++) {
        const float lo = a[i] * (1.0f - 0x1p-21f) - 0x1p-122f, hi = b[i] * (1.0f + 0x1p-21f) + 0x1p-122f;
        dist[i] = lo;
        mask |= (unsigned)(lo <= hi) << i;
    }
    return mask;
#endif
}

/* The set-up of the FMA node test (node_bvh8_slab.h) for a non-parallel
 * ray in the top tree: sc_ray_precompute's slab constants alone (the
 * triangle tests' shear is not needed here), with the distance bound of
 * each axis raised by X = E / 2u: the padding is about 2u m in space, so
 * the growth E is folded into it (10 % over, for the float roundings
 * here). All in float: the largest distance m of the origin from the top
 * box's planes, rounded to nearest, is at least (1 - u) of the exact one,
 * which sc_top_growth_consts allows for; each bound
 * fl(fl(d_k + X) (1 + 2^-20)) is at least d_k + X for the same reason.
 * The x86 kernels compute the same operations in one xmm register
 * (traverse_top_bvh8.h). */
#define SC_TOP_X_SCALE (0x1p23f * 1.1f * (1.0f + 0x1p-20f))
#define SC_TOP_M_UP (1.0f + 0x1p-20f)
static inline void sc_top_pre(const sc_top *T, const sc_ray *r, sc_ray_pre *p)
{
    float dk[3];
    for (int k = 0; k < 3; k++) {
        const float dl = fabsf(T->lo[k] - r->org[k]), dh = fabsf(T->hi[k] - r->org[k]);
        dk[k] = dl > dh ? dl : dh;
    }
    float m = dk[0] > dk[1] ? dk[0] : dk[1];
    m = dk[2] > m ? dk[2] : m;
    const float X = fmaf(m, T->grow_a, T->grow_b) * SC_TOP_X_SCALE;
    for (int k = 0; k < 3; k++) {
        const float mk = (dk[k] + X) * SC_TOP_M_UP;
        p->org[k] = r->org[k];
        p->dir[k] = r->dir[k];
        p->rd[k] = 1.0f / r->dir[k];
        sc_slab_offsets(p->org[k], p->rd[k], mk, &p->ord_near[k], &p->ord_far[k]);
        const int neg = signbit(p->rd[k]) != 0;
        p->near_row[k] = 2 * k + neg;
        p->far_row[k] = 2 * k + 1 - neg;
        p->rdp[k] = 0;
    }
    p->tmin = r->tmin;
    p->tmax = r->tmax;
    p->parallel = 0;
    p->kx = 0, p->ky = 1, p->kz = 2;
    p->Sx = p->Sy = p->Sz = 0;
    p->xK = p->xc0 = 0;
}

#endif

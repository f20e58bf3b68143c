/* The exact-decision triangle test (SC_TRI_EXACT): the SIMD kernels run the
 * float Woop et al. test together with a rigorous forward error bound; a
 * lane whose edge functions are all farther from zero than their bounds,
 * and whose t is certainly outside the current range, is decided there.
 * Every other lane of a leaf comes here, in lane order:
 *
 *   1. a double-precision filter (edge volumes with error bounds, a t
 *      interval from the barycentric form of t);
 *   2. where that cannot decide, exact integer arithmetic: every predicate is
 *      a sum of signed products of three floats, and a product of three
 *      float significands (72 bits, unsigned __int128) times a power of two
 *      is added into a fixed-point accumulator (two's complement, 2^-447
 *      units), so the sign is exact. The comparison of two t = num/den is
 *      the sign of num1 den2 - num2 den1, exact with a schoolbook multiply.
 *
 * The predicates are the oracle's (src/reference/ref_ray.c): with
 * a = A-O, b = B-O, c = C-O, the ray meets the triangle iff the volumes
 * D.(b x c), D.(c x a), D.(a x b) have no two opposite signs and their sum
 * D.n is non-zero (both faces, edges and vertices included, a ray in the
 * triangle's plane never hits); t = a.n / D.n must satisfy tmin <= t <= tmax
 * exactly; the first hit is the smallest exact t, and of exact ties the
 * smallest primitive id (all of them are in the oracle's tie set).
 * libc and libm only.
 */
#ifndef SPHERECULL_TRACE_TRI_EXACT_H
#define SPHERECULL_TRACE_TRI_EXACT_H

#include <math.h>
#include <stdint.h>

#include "spherecull/sc_prefilter.h"
#include "tri_watertight.h"

/* One accepted hit, or the current closest. lo <= exact t <= hi always.
 * What is reported (t, u, v, and whether sc_exact_finish recomputes them
 * within [rlo, rhi]) is fixed when the hit is accepted, from the ray and
 * the triangle alone: comparisons with other hits only tighten lo and hi.
 * So a hit's reported values do not depend on which hits it met first, and
 * every traversal order (leaf sizes, ISAs, brute force) reports the same
 * bits. */
typedef struct sc_exact_hit {
    int have;
    int refined;            /* lo, hi come from the double filter (tighter) */
    uint32_t prim;
    const float *rows;      /* the triangle: lane `lane` of a leaf block of width W */
    unsigned W, lane;
    float lo, hi;
    float rlo, rhi;         /* lo, hi when accepted: the report's bounds */
    float t, u, v;          /* reported: t (in [tmin, tmax]) and barycentrics */
} sc_exact_hit;

/* The float filter of the scalar and SIMD kernels (u = 2^-24): with the
 * sheared float coordinates Px, Py of a vertex P, h = |Px| + |Py|, an edge
 * function over vertices P, Q is certain iff its magnitude exceeds
 *   E = K (hP + hQ) + c0,
 * K and c0 per ray from S >= the largest L1 distance of the BVH's root box
 * from the origin (sc_exact_consts in ray_setup.h), and on a lane with three certain
 * edges of one sign t = T fl(1/det) is within
 *   te = (R * SC_EXACT_K202 * (E1+E2+E3) + SC_EXACT_FLOOR_N) |fl(1/det)|
 *        + Z * SC_EXACT_K15U + |t| * SC_EXACT_K3U + SC_EXACT_FLOOR_T
 * of the exact t, with zi = Sz z_i (the vertices' t along the ray),
 * Z = max |zi| and R = (max zi - min zi) / 2 (the spread: barycentric
 * errors sum to zero, so they only move t within the triangle's depth).
 * In te, K and c0 come from the triangle's own S where that is below the
 * root box's (sc_exact_local_bound). The derivation is in tri_exact.c. */
#define SC_EXACT_K202 (2.02f)
/* The kernels certify the edges with one bound per lane for all three,
 * E1 = K (hA + hB + hC) + c0 >= each edge's E: looser by at most 2x, which
 * only sends a few more lanes to sc_exact_resolve; six operations fewer per
 * leaf. The t bound takes the edge sum itself, E1+E2+E3 = 2 K (hA + hB + hC)
 * + 3 c0 (sc_exact_local_bound), not 3 E1: a third less where the t bound
 * decides whether sc_exact_finish recomputes a hit (a grazing one). */
#define SC_EXACT_FLOOR_N (0x1p-123f)   /* normal: holds under MXCSR FTZ|DAZ (tri_exact.c) */
#define SC_EXACT_K15U (15.0f * 0x1p-24f)
#define SC_EXACT_K3U (3.0f * 0x1p-24f)
#define SC_EXACT_FLOOR_T (0x1p-120f)

/* The common case, inline in the kernels: a lane whose float filter
 * certified the edges (te >= 0). Since te >= 3u|t|, fl(t - 2te) <= t - te
 * and fl(t + 2te) >= t + te, so [lo, hi] below holds the exact t. Returns 1
 * when that decides the lane (*take: it is the new closest), 0 when
 * sc_exact_resolve must (a range or order too close to call in float). */
static inline int sc_exact_fast(const sc_ray *r, float t, float te, const sc_exact_hit *best, int *take, float *lo,
                           float *hi)
{
    float L = t - 2 * te, H = t + 2 * te;
    if (!(L >= r->tmin && H <= r->tmax))
        return 0;
    *lo = L, *hi = H;
    if (!best->have || H < best->lo) {
        *take = 1;
        return 1;
    }
    *take = 0;
    return L > best->hi;
}

/* Settles the candidate lanes `cand` of one leaf block (vertex rows as in
 * bvh_internal.h, width W). Per lane, te[i] >= 0 means the float filter
 * certified the edges (all inside) and |t[i] - exact t| <= te[i], with
 * un/vn its barycentric numerators and den = 1/det; te[i] < 0 means
 * undecided. With
 * any != 0 returns 1 at the first exact hit in [tmin, tmax]; otherwise
 * updates *best and returns the number of exact hits in [tmin, tmax]. */
__attribute__((cold)) unsigned sc_exact_resolve(const sc_ray *r, const float *rows, unsigned W, unsigned cand, const float *t,
                     const float *te, const float *un, const float *vn, const float *den, int any,
                     sc_exact_hit *best);

/* The float t of a certified lane can be far from the exact one when the
 * ray grazes the triangle (wide [lo, hi]); then the reported t, u, v are
 * recomputed in double. Called once per ray on the final closest hit. */
__attribute__((cold)) void sc_exact_report(const sc_ray *r, sc_exact_hit *best);
/* [rlo, rhi] wider than this times |t|: recomputed */
#define SC_EXACT_REPORT_WIDTH 0x1p-12f
static inline void sc_exact_finish(const sc_ray *r, sc_exact_hit *best)
{
    if (best->have && !(best->rhi - best->rlo <= SC_EXACT_REPORT_WIDTH * fabsf(best->t)))
        sc_exact_report(r, best);
}

/* Exact primitives, exposed for the tests. v = A, B, C (9 floats). */
/* sign of D.((P-O) x (Q-O)) */
int sc_exact_vol_sign(const sc_ray *r, const float P[3], const float Q[3]);
/* 1 iff the ray hits the triangle in [tmin, tmax] (the oracle's rule) */
int sc_exact_hit_test(const sc_ray *r, const float v[9]);
/* sign of t(a) - t(b) for two triangles whose planes the ray crosses */
int sc_exact_cmp_t(const sc_ray *r, const float a[9], const float b[9]);

/* A t bound this narrow (times |t|) is half of what sc_exact_finish lets
 * through (its [t - 2 te, t + 2 te] within SC_EXACT_REPORT_WIDTH |t|, so
 * te up to a quarter of that): test_exact_tri requires the local bound
 * below to reach it where the root box's could not. */
#define SC_EXACT_WIDE (SC_EXACT_REPORT_WIDTH / 8)

/* The sum of one triangle's three edge bounds for its t bound,
 * 2 K (hA + hB + hC) + 3 c0 (2K exact, 3 c0 and the FMA one rounding each,
 * inside the 1 % of SC_EXACT_K202), with K and c0 from the triangle's own
 * S (sc_exact_consts' formulas) where that is below the ray's. The
 * derivation (tri_exact.c) needs S >= |a|_1, a = fl(P - O), for
 * the vertices of the edges it bounds, not for the whole root box: here
 * |a|_1 <= h + (1 + |Sx| + |Sy|) |a_kz| (the shear undone; h = |Px| + |Py|),
 * evaluated here in float: sums of positive terms with at most four
 * roundings, below 5u relative, inside the 0.07 % the constants carry for
 * the rounding of S (a flushed product under FTZ|DAZ errs by below 4 MIN
 * absolute, inside K's and c0's floors). The root box's S is the farthest
 * corner: for a hit near the origin (rays that start inside the model) it
 * overstates the error by the model's size over the hit's distance, and a
 * t bound that loose sends the hit to sc_exact_finish's double recompute
 * (a third of the random rays' hits on the bunny). Only the t bound uses
 * it, on every lane whose edges are certain, without a branch on whether
 * the ray's own bound is wide: for rays that start at or inside the model
 * that branch goes either way from leaf to leaf and mispredicts
 * (docs/compare.md, fortieth session). The edges are certified with E1,
 * whose one bound per ray costs nothing per lane. */
SC_TRACE_INLINE float sc_exact_local_bound(float xK, float xc0, float Sx, float Sy, float hA, float hB, float hC,
                                           float Akz, float Bkz, float Ckz)
{
    const float sxy = (1.0f + fabsf(Sx)) + fabsf(Sy);
    const float S = sc_fmax(sc_fmax(fmaf(sxy, fabsf(Akz), hA), fmaf(sxy, fabsf(Bkz), hB)), fmaf(sxy, fabsf(Ckz), hC));
    const float K = sc_fmin(sc_exact_k(S), xK), c0 = sc_fmin(sc_exact_c0(S), xc0);
    return fmaf(K + K, (hA + hB) + hC, c0 * 3.0f);
}

/* The float filter of the exact test (SC_TRI_EXACT): the watertight
 * arithmetic plus the forward error bounds of tri_exact.h. Returns 0 for a
 * certain miss (two edges of certainly opposite signs, or t certainly
 * outside [tmin, tmax]); 1 leaves the lane to sc_exact_resolve, with te >= 0 and
 * t, un, vn and den = 1/det set when all three edges are certain (inside),
 * te = -1 otherwise. Every SIMD kernel computes the same bits. */
SC_TRACE_INLINE int sc_tri_exact_filter(const sc_ray_pre *p, const float *rows, unsigned W, unsigned i, float tmin,
                             float tmax, float *t, float *te, float *un, float *vn, float *den)
{
    sc_tri_sheared sh;
    sc_tri_shear(p, rows, W, i, &sh);
    const float Ax = sh.Ax, Ay = sh.Ay, Bx = sh.Bx, By = sh.By, Cx = sh.Cx, Cy = sh.Cy;
    const float U = sh.U, V = sh.V, Wf = sh.W;
    float hA = fabsf(Ax) + fabsf(Ay), hB = fabsf(Bx) + fabsf(By), hC = fabsf(Cx) + fabsf(Cy);
    /* one bound for the three edges (see SC_EXACT_K202) */
    float E1 = fmaf(p->xK, (hA + hB) + hC, p->xc0), nE1 = -E1;
    int pU = U > E1, pV = V > E1, pW = Wf > E1;
    int nU = U < nE1, nV = V < nE1, nW = Wf < nE1;
    *te = -1;
    if ((pU | pV | pW) & (nU | nV | nW))
        return 0;
    if (!((pU & pV & pW) | (nU & nV & nW)))
        return 1;
    float Az = p->Sz * sh.Akz, Bz = p->Sz * sh.Bkz, Cz = p->Sz * sh.Ckz;
    float det = (U + V) + Wf;
    float T = (U * Az + V * Bz) + Wf * Cz;
    float inv = 1.0f / det;
    float tt = T * inv;
    float zmax = sc_fmax(sc_fmax(Az, Bz), Cz), zmin = sc_fmin(sc_fmin(Az, Bz), Cz);
    float Z = sc_fmax(zmax, -zmin), R = (zmax - zmin) * 0.5f;
    const float zt = fmaf(Z, SC_EXACT_K15U, fmaf(fabsf(tt), SC_EXACT_K3U, SC_EXACT_FLOOR_T));
    const float El = sc_exact_local_bound(p->xK, p->xc0, p->Sx, p->Sy, hA, hB, hC, sh.Akz, sh.Bkz, sh.Ckz);
    const float e = fmaf(fmaf(R, El * SC_EXACT_K202, SC_EXACT_FLOOR_N), fabsf(inv), zt);
    if (!(e < INFINITY) || !(fabsf(inv) >= 0x1p-126f))   /* 1/det subnormal or flushed: undecided */
        return 1;
    if (tt - e > tmax || tt + e < tmin)
        return 0;
    *t = tt, *te = e, *un = V, *vn = Wf, *den = inv;
    return 1;
}

#endif

/* Portable kernels: the specification every SIMD kernel must match bit for
 * bit (same operations, same order, no FMA), and the fallback for CPUs
 * without AVX2. */
#include "trace_common.h"

#define KFN(name) name##_scalar
#define KATTR
typedef struct { sc_ray_pre pre; const sc_ray_pre *p; } ctx_scalar;
#define KCTX ctx_scalar

static inline void KFN(ctx_init)(KCTX *c, const sc_ray_pre *p) { c->pre = *p, c->p = &c->pre; }
/* The set-up of non-parallel rays: here the same as the generic one. */
static inline void KFN(ctx_fast)(KCTX *c, const sc_ray *r, const sc_bvh *bvh)
{
    sc_ray_pre p;
    sc_ray_precompute(r, &p, bvh->root_lo, bvh->root_hi);
    KFN(ctx_init)(c, &p);
}

static inline unsigned KFN(node_test)(const KCTX *c, const sc_bvh_node8 *node, float tmin, float tmax,
                                      float *dist, const int OCT, const int WANT_DIST)
{
    (void)OCT, (void)WANT_DIST;
    return sc_slab(c->p, node, tmin, tmax, dist);
}

static inline unsigned KFN(node_test_par)(const KCTX *c, const sc_bvh_node8 *node, float tmin, float tmax,
                                          float *dist)
{
    return sc_slab_par(c->p, node, tmin, tmax, dist);
}

/* The triangle of lane i in the ray's sheared frame (Woop et al.: translate
 * by the origin, permute so kz is the dominant axis, shear) and its three
 * edge functions; shared by the watertight and the exact test, which must see
 * the same bits. */
typedef struct lane_sheared {
    float Ax, Ay, Bx, By, Cx, Cy;   /* sheared 2D vertices */
    float Akz, Bkz, Ckz;            /* translated depth components, unscaled */
    float U, V, W;                  /* edge functions */
} lane_sheared;

static inline void lane_shear(const sc_ray_pre *p, const float *rows, unsigned W, unsigned i,
                              lane_sheared *s)
{
    const int kx = p->kx, ky = p->ky, kz = p->kz;
    float A[3], B[3], C[3];
    for (int k = 0; k < 3; k++) {
        A[k] = rows[(0 + k) * W + i] - p->org[k];
        B[k] = rows[(3 + k) * W + i] - p->org[k];
        C[k] = rows[(6 + k) * W + i] - p->org[k];
    }
    s->Ax = A[kx] - p->Sx * A[kz], s->Ay = A[ky] - p->Sy * A[kz];
    s->Bx = B[kx] - p->Sx * B[kz], s->By = B[ky] - p->Sy * B[kz];
    s->Cx = C[kx] - p->Sx * C[kz], s->Cy = C[ky] - p->Sy * C[kz];
    s->U = s->Cx * s->By - s->Cy * s->Bx;
    s->V = s->Ax * s->Cy - s->Ay * s->Cx;
    s->W = s->Bx * s->Ay - s->By * s->Ax;
    s->Akz = A[kz], s->Bkz = B[kz], s->Ckz = C[kz];
}

/* Watertight test of one lane (Woop, Benthin, Wald 2013). */
static inline int lane_watertight(const sc_ray_pre *p, const float *rows, unsigned W, unsigned i,
                                  float tmin, float tmax, float *t, float *un, float *vn, float *den)
{
    lane_sheared sh;
    lane_shear(p, rows, W, i, &sh);
    const float Ax = sh.Ax, Ay = sh.Ay, Bx = sh.Bx, By = sh.By, Cx = sh.Cx, Cy = sh.Cy;
    const float U = sh.U, V = sh.V, Wf = sh.W;
    float Az = p->Sz * sh.Akz, Bz = p->Sz * sh.Bkz, Cz = p->Sz * sh.Ckz;
    if (U == 0 || V == 0 || Wf == 0) {
        float u, v;
        if (!sc_watertight_double(Ax, Ay, Bx, By, Cx, Cy, Az, Bz, Cz, tmin, tmax, t, &u, &v))
            return 0;
        *un = u, *vn = v, *den = 1;
        return 1;
    }
    if ((U < 0 || V < 0 || Wf < 0) && (U > 0 || V > 0 || Wf > 0))
        return 0;
    float det = (U + V) + Wf;
    if (det == 0)
        return 0;
    float T = (U * Az + V * Bz) + Wf * Cz;
    float tt = T / det;
    if (!(tt >= tmin && tt <= tmax))
        return 0;
    *t = tt, *un = V, *vn = Wf, *den = det;
    return 1;
}

/* The float filter of the exact test (SC_TRI_EXACT): the watertight
 * arithmetic plus the forward error bounds of exact_tri.h. Returns 0 for a
 * certain miss (two edges of certainly opposite signs, or t certainly
 * outside [tmin, tmax]); 1 leaves the lane to sc_xresolve, with te >= 0 and
 * t, un, vn and den = 1/det set when all three edges are certain (inside),
 * te = -1 otherwise. Every SIMD kernel computes the same bits. */
static inline int lane_exact(const sc_ray_pre *p, const float *rows, unsigned W, unsigned i, float tmin,
                             float tmax, float *t, float *te, float *un, float *vn, float *den)
{
    lane_sheared sh;
    lane_shear(p, rows, W, i, &sh);
    const float Ax = sh.Ax, Ay = sh.Ay, Bx = sh.Bx, By = sh.By, Cx = sh.Cx, Cy = sh.Cy;
    const float U = sh.U, V = sh.V, Wf = sh.W;
    float hA = fabsf(Ax) + fabsf(Ay), hB = fabsf(Bx) + fabsf(By), hC = fabsf(Cx) + fabsf(Cy);
    /* one bound for the three edges (see SC_X_K606) */
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
    float q = fmaf(R, E1 * SC_X_K606, SC_X_FLOOR_N);
    float e = fmaf(q, fabsf(inv), fmaf(Z, SC_X_K15U, fmaf(fabsf(tt), SC_X_K3U, SC_X_FLOOR_T)));
    if (!(e < INFINITY) || !(fabsf(inv) >= 0x1p-126f))   /* 1/det subnormal or flushed: undecided */
        return 1;
    if (tt - e > tmax || tt + e < tmin)
        return 0;
    *t = tt, *te = e, *un = V, *vn = Wf, *den = inv;
    return 1;
}

/* Moller-Trumbore 1997, both faces. */
static inline int lane_moller(const sc_ray_pre *p, const float *rows, unsigned W, unsigned i,
                              float tmin, float tmax, float *t, float *un, float *vn, float *den)
{
    float v0[3], e1[3], e2[3], s[3];
    for (int k = 0; k < 3; k++) {
        v0[k] = rows[k * W + i];
        e1[k] = rows[(3 + k) * W + i] - v0[k];
        e2[k] = rows[(6 + k) * W + i] - v0[k];
        s[k] = p->org[k] - v0[k];
    }
    const float *d = p->dir;
    float px = d[1] * e2[2] - d[2] * e2[1];
    float py = d[2] * e2[0] - d[0] * e2[2];
    float pz = d[0] * e2[1] - d[1] * e2[0];
    float det = (e1[0] * px + e1[1] * py) + e1[2] * pz;
    float inv = 1.0f / det;
    float u = ((s[0] * px + s[1] * py) + s[2] * pz) * inv;
    float qx = s[1] * e1[2] - s[2] * e1[1];
    float qy = s[2] * e1[0] - s[0] * e1[2];
    float qz = s[0] * e1[1] - s[1] * e1[0];
    float v = ((d[0] * qx + d[1] * qy) + d[2] * qz) * inv;
    float tt = ((e2[0] * qx + e2[1] * qy) + e2[2] * qz) * inv;
    if (det != 0 && u >= 0 && v >= 0 && u + v <= 1 && tt >= tmin && tt <= tmax) {
        *t = tt, *un = u, *vn = v, *den = 1;
        return 1;
    }
    return 0;
}

static inline unsigned KFN(leaf_test)(const KCTX *c, const float *rows, unsigned W, unsigned live,
                                      float tmin, float tmax, int test, float *t, float *te, float *un,
                                      float *vn, float *den)
{
    unsigned hm = 0;
    for (unsigned m = live; m; m &= m - 1) {
        unsigned i = (unsigned)__builtin_ctz(m);
        int h = test == SC_TRI_MOLLER ? lane_moller(c->p, rows, W, i, tmin, tmax, &t[i], &un[i], &vn[i], &den[i])
                : test == SC_TRI_EXACT
                    ? lane_exact(c->p, rows, W, i, tmin, tmax, &t[i], &te[i], &un[i], &vn[i], &den[i])
                    : lane_watertight(c->p, rows, W, i, tmin, tmax, &t[i], &un[i], &vn[i], &den[i]);
        hm |= (unsigned)h << i;
    }
    return hm;
}

#include "traverse_core_template.h"

/* Every leaf, no box tests, no prefilter: a same-arithmetic oracle for the
 * traversal (it can only differ on exact ties in t). */
sc_status sc_trace_closest_brute(const sc_bvh *bvh, const sc_ray *ray, sc_hitrec *hit)
{
    if (!bvh || !ray || !hit || !sc_ray_valid(ray))
        return SC_ERR_INVALID_ARGUMENT;
    sc_ray_pre p;
    sc_ray_precompute(ray, &p, bvh->root_lo, bvh->root_hi);
    ctx_scalar c;
    ctx_init_scalar(&c, &p);
    float tmax = ray->tmax;
    hit->prim = SC_HITREC_MISS;
    hit->t = ray->tmax;
    hit->u = hit->v = 0;
    if (!bvh->has_root)
        return SC_OK;
    const int test = bvh->cfg.tri_test;
    sc_xhit xb;
    xb.have = 0;
    for (size_t ni = 0; ni < bvh->node_count; ni++) {
        const sc_bvh_node8 *node = &bvh->nodes[ni];
        for (int s = 0; s < SC_BVH_N; s++) {
            uint64_t ref = node->child[s];
            if (!sc_ref_is_leaf(ref))
                continue;
            const unsigned n = sc_ref_count(ref), W = sc_leaf_width(n);
            const float *rows = (const float *)(const void *)(bvh->leaves + sc_ref_offset(ref));
            if (sc_ref_has_spheres(ref))
                rows += 4 * W;
            float t[16], te[16], un[16], vn[16], den[16];
            unsigned hm = leaf_test_scalar(&c, rows, W, (1u << n) - 1, ray->tmin, tmax, test, t, te, un, vn, den);
            if (!hm)
                continue;
            if (test == SC_TRI_EXACT) {
                sc_xresolve(ray, rows, W, hm, t, te, un, vn, den, 0, &xb);
                if (xb.have) {
                    tmax = xb.hi;
                    sc_xhit_finish(ray, &xb);
                    hit->prim = xb.prim;
                    hit->t = xb.t;
                    hit->u = xb.u;
                    hit->v = xb.v;
                }
                continue;
            }
            int bi = __builtin_ctz(hm);
            for (unsigned rest = hm & (hm - 1); rest; rest &= rest - 1) {
                int i = __builtin_ctz(rest);
                if (t[i] < t[bi])
                    bi = i;
            }
            tmax = t[bi];
            hit->t = t[bi];
            hit->prim = ((const uint32_t *)(const void *)(rows + 9 * W))[bi];
            hit->u = un[bi] / den[bi];
            hit->v = vn[bi] / den[bi];
        }
    }
    return SC_OK;
}

/* Watertight ray-triangle test (Woop, Benthin, Wald 2013), one lane of a
 * leaf block: the scalar specification. tri_watertight_x86.h computes the
 * same bits on 8 lanes.
 *
 * The shear puts the ray on the +z axis; the edge functions of a shared edge
 * are then computed from identical operands with opposite signs, so a ray
 * cannot slip between two triangles that share an edge as long as each
 * edge function's sign is decided consistently. An edge function that is
 * exactly zero in float sends all three to double (sc_watertight_double),
 * where the products of floats are exact. What this does not promise: the
 * float edge functions carry rounding, so near an edge or vertex the test
 * may report the neighbour, miss a touch, or hit a ray that misses by an
 * ulp; tri_exact.h decides those exactly.
 */
#ifndef SPHERECULL_TRACE_TRI_WATERTIGHT_H
#define SPHERECULL_TRACE_TRI_WATERTIGHT_H

#include "bvh/leaf_block.h"
#include "ray_setup.h"

/* The triangle of lane i in the ray's sheared frame (Woop et al.: translate
 * by the origin, permute so kz is the dominant axis, shear) and its three
 * edge functions; shared by the watertight and the exact test, which must see
 * the same bits. */
typedef struct sc_tri_sheared {
    float Ax, Ay, Bx, By, Cx, Cy;   /* sheared 2D vertices */
    float Akz, Bkz, Ckz;            /* translated depth components, unscaled */
    float U, V, W;                  /* edge functions */
} sc_tri_sheared;

SC_TRACE_INLINE void sc_tri_shear(const sc_ray_pre *p, const float *rows, unsigned W, unsigned i,
                              sc_tri_sheared *s)
{
    const int kx = p->kx, ky = p->ky, kz = p->kz;
    float A[3], B[3], C[3];
    for (int k = 0; k < 3; k++) {
        A[k] = rows[sc_leaf_at(W, 0, k, i)] - p->org[k];
        B[k] = rows[sc_leaf_at(W, 1, k, i)] - p->org[k];
        C[k] = rows[sc_leaf_at(W, 2, k, i)] - p->org[k];
    }
    s->Ax = A[kx] - p->Sx * A[kz], s->Ay = A[ky] - p->Sy * A[kz];
    s->Bx = B[kx] - p->Sx * B[kz], s->By = B[ky] - p->Sy * B[kz];
    s->Cx = C[kx] - p->Sx * C[kz], s->Cy = C[ky] - p->Sy * C[kz];
    s->U = s->Cx * s->By - s->Cy * s->Bx;
    s->V = s->Ax * s->Cy - s->Ay * s->Cx;
    s->W = s->Bx * s->Ay - s->By * s->Ax;
    s->Akz = A[kz], s->Bkz = B[kz], s->Ckz = C[kz];
}

/* Woop et al. 2013, section 4: when an edge function is exactly zero in
 * float, all three are recomputed in double from the same float inputs. The
 * products of floats are exact in double, so U(a,b) = -U(b,a) still holds
 * and a neighbouring triangle sees the same decision. Returns 1 on a hit in
 * [tmin, tmax] and writes t and the barycentrics. */
SC_TRACE_INLINE int sc_watertight_double(float Ax, float Ay, float Bx, float By, float Cx, float Cy,
                                       float Az, float Bz, float Cz, float tmin, float tmax,
                                       float *t, float *u, float *v)
{
    double U = (double)Cx * By - (double)Cy * Bx;
    double V = (double)Ax * Cy - (double)Ay * Cx;
    double W = (double)Bx * Ay - (double)By * Ax;
    if ((U < 0 || V < 0 || W < 0) && (U > 0 || V > 0 || W > 0))
        return 0;
    double det = U + V + W;
    if (det == 0)
        return 0;
    double T = U * Az + V * Bz + W * Cz;
    float tt = (float)(T / det);
    if (!(tt >= tmin && tt <= tmax))
        return 0;
    *t = tt;
    *u = (float)(V / det);
    *v = (float)(W / det);
    return 1;
}

/* Watertight test of one lane (Woop, Benthin, Wald 2013). */
SC_TRACE_INLINE int sc_tri_watertight(const sc_ray_pre *p, const float *rows, unsigned W, unsigned i,
                                  float tmin, float tmax, float *t, float *un, float *vn, float *den)
{
    sc_tri_sheared sh;
    sc_tri_shear(p, rows, W, i, &sh);
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

#endif

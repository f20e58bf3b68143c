/* Watertight ray-triangle test (Woop, Benthin, Wald 2013) for the Embree
 * user-geometry drop-in. Private: when the tracer's own watertight test is
 * public (sc_trace.h) this one should go in favour of it.
 *
 * The shear puts the ray on the +z axis; edge functions of shared edges are
 * then computed from identical operands with opposite signs, so a ray cannot
 * slip between two triangles that share an edge — as long as every edge
 * function's sign is exact, which is why they are evaluated in double (see
 * wt_intersect). */
#ifndef SPHERECULL_EMBREE_WATERTIGHT_H
#define SPHERECULL_EMBREE_WATERTIGHT_H

#include <math.h>

typedef struct wt_ray {
    float org[3];
    int kx, ky, kz;
    float Sx, Sy, Sz;
} wt_ray;

static inline void wt_ray_init(wt_ray *w, const float org[3], const float dir[3])
{
    float ax = fabsf(dir[0]), ay = fabsf(dir[1]), az = fabsf(dir[2]);
    int kz = ax > ay ? (ax > az ? 0 : 2) : (ay > az ? 1 : 2);
    int kx = (kz + 1) % 3, ky = (kx + 1) % 3;
    if (dir[kz] < 0) {                    /* keep the winding of the sheared triangle */
        int tmp = kx;
        kx = ky, ky = tmp;
    }
    w->kx = kx, w->ky = ky, w->kz = kz;
    w->Sx = dir[kx] / dir[kz];
    w->Sy = dir[ky] / dir[kz];
    w->Sz = 1.0f / dir[kz];
    w->org[0] = org[0], w->org[1] = org[1], w->org[2] = org[2];
}

/* v: A, B, C as 9 floats. Hit in [tmin, tmax) -> 1 with *t, *u, *v set. */
static inline int wt_intersect(const wt_ray *r, const float *v, float tmin, float tmax, float *t_out,
                               float *u_out, float *v_out)
{
    const int kx = r->kx, ky = r->ky, kz = r->kz;
    float A[3], B[3], C[3];
    for (int k = 0; k < 3; k++) {
        A[k] = v[k] - r->org[k];
        B[k] = v[3 + k] - r->org[k];
        C[k] = v[6 + k] - r->org[k];
    }
    const float Ax = A[kx] - r->Sx * A[kz], Ay = A[ky] - r->Sy * A[kz];
    const float Bx = B[kx] - r->Sx * B[kz], By = B[ky] - r->Sy * B[kz];
    const float Cx = C[kx] - r->Sx * C[kz], Cy = C[ky] - r->Sy * C[kz];
    /* Always in double: float products are exact there and one rounded
     * difference keeps the exact sign, so the edge shared by two triangles
     * gets opposite signs in both. The paper's float evaluation with a
     * double fallback only on exact zeros is not enough: a triangle that
     * falls back next to one that does not can disagree on their shared
     * edge's sign, and a ray through a vertex then misses all of its
     * triangles (measured on the closed icosphere, tests/test_embree.c). */
    const double U = (double)Cx * By - (double)Cy * Bx;
    const double V = (double)Ax * Cy - (double)Ay * Cx;
    const double W = (double)Bx * Ay - (double)By * Ax;
    if ((U < 0 || V < 0 || W < 0) && (U > 0 || V > 0 || W > 0))
        return 0;
    const double det = U + V + W;
    if (det == 0)
        return 0;
    const double Az = (double)r->Sz * A[kz], Bz = (double)r->Sz * B[kz], Cz = (double)r->Sz * C[kz];
    const double T = U * Az + V * Bz + W * Cz;
    const float t = (float)(T / det);
    if (!(t >= tmin && t < tmax))
        return 0;
    *t_out = t;
    *u_out = (float)(V / det);
    *v_out = (float)(W / det);
    return 1;
}

#endif

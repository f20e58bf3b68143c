/* The conservative double filter shared by the exact oracle (oracle.c) and
 * the crossing classifier (crossing.c): both must reject exactly the same
 * triangles, so there is one copy. Internal to src/compare. */
#ifndef SC_COMPARE_TRI_FILTER_H
#define SC_COMPARE_TRI_FILTER_H

#include <math.h>

/* Relative slack: every product below is of float differences, each
 * rounding is below 2^-52 of the L1 bound REL multiplies, so ~1e-15 of
 * the bound at most. */
#define SC_TRI_FILTER_REL 1e-12

static inline double sc_tf_dot(const double a[3], const double b[3])
{
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
}
static inline double sc_tf_l1(const double a[3])
{
    return fabs(a[0]) + fabs(a[1]) + fabs(a[2]);
}
static inline void sc_tf_cross(double o[3], const double a[3], const double b[3])
{
    o[0] = a[1] * b[2] - a[2] * b[1];
    o[1] = a[2] * b[0] - a[0] * b[2];
    o[2] = a[0] * b[1] - a[1] * b[0];
}

/* 0: the triangle v (3 vertices, each a float widened to double) certainly
 * misses the ray O + tD within [tmin, tmax]. Else 1 and *t_lo is a lower
 * bound of its exact t (tmin when unknown). The L1 norms bound the
 * magnitude of every product summed, so REL times them bounds the rounding. */
static inline int sc_tri_filter(const double v[9], const double O[3], const double D[3], double tmin,
                                double tmax, double *t_lo)
{
    const double REL = SC_TRI_FILTER_REL;
    double a[3], b[3], c[3], x[3];
    for (int k = 0; k < 3; k++) {
        a[k] = v[k] - O[k];
        b[k] = v[3 + k] - O[k];
        c[k] = v[6 + k] - O[k];
    }
    double dl = sc_tf_l1(D), al = sc_tf_l1(a), bl = sc_tf_l1(b), cl = sc_tf_l1(c);
    sc_tf_cross(x, b, c);
    double v0 = sc_tf_dot(D, x), e0 = REL * dl * bl * cl;
    sc_tf_cross(x, c, a);
    double v1 = sc_tf_dot(D, x), e1 = REL * dl * cl * al;
    sc_tf_cross(x, a, b);
    double v2 = sc_tf_dot(D, x), e2 = REL * dl * al * bl;
    int pos = v0 > e0 || v1 > e1 || v2 > e2;
    int neg = v0 < -e0 || v1 < -e1 || v2 < -e2;
    if (pos && neg)
        return 0;
    *t_lo = tmin;
    double f1[3], f2[3], n[3];
    for (int k = 0; k < 3; k++)
        f1[k] = v[3 + k] - v[k], f2[k] = v[6 + k] - v[k];
    sc_tf_cross(n, f1, f2);
    double nl = sc_tf_l1(f1) * sc_tf_l1(f2);
    double num = sc_tf_dot(a, n), en = REL * al * nl;
    double den = sc_tf_dot(D, n), ed = REL * dl * nl;
    if (!(fabs(den) > 2 * ed))
        return 1;                                   /* near-parallel: decide exactly */
    double q[4] = { (num - en) / (den - ed), (num - en) / (den + ed), (num + en) / (den - ed),
                    (num + en) / (den + ed) };
    double lo = q[0], hi = q[0];
    for (int k = 1; k < 4; k++) {
        if (q[k] < lo) lo = q[k];
        if (q[k] > hi) hi = q[k];
    }
    lo -= REL * fabs(lo);
    hi += REL * fabs(hi);
    if (hi < tmin || lo > tmax)
        return 0;
    *t_lo = lo > tmin ? lo : tmin;
    return 1;
}

#endif

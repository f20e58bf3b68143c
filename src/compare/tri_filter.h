/* The conservative double filter shared by the exact oracle (oracle.c) and
 * the crossing classifier (crossing.c): both must reject exactly the same
 * triangles, so there is one copy; and the padded box test by which the
 * oracle and bench's brute-force check skip whole clusters or objects.
 * Internal to src/compare. */
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

/* Widens box (lo[3], hi[3], of float coordinates) outward generously: the
 * slab test below only needs to err outwards. */
static inline void sc_tf_box_pad(double b[6])
{
    for (int a = 0; a < 3; a++) {
        const double pad = 1e-7 * ((b[3 + a] - b[a]) + fmax(fabs(b[a]), fabs(b[3 + a]))) + 1e-300;
        b[a] -= pad;
        b[3 + a] += pad;
    }
}

/* 0: the ray O + tD certainly misses the (padded) box within [tmin, tmax];
 * 1 otherwise (also whenever the arithmetic is in doubt). */
static inline int sc_tf_box_may_hit(const double *b, const double O[3], const double D[3], double tmin, double tmax)
{
    double tn = -INFINITY, tf = INFINITY;
    for (int a = 0; a < 3; a++) {
        if (D[a] == 0) {
            if (O[a] < b[a] || O[a] > b[3 + a])
                return 0;
            continue;
        }
        double t1 = (b[a] - O[a]) / D[a], t2 = (b[3 + a] - O[a]) / D[a];
        if (t1 > t2) {
            double s = t1;
            t1 = t2, t2 = s;
        }
        if (t1 > tn) tn = t1;
        if (t2 < tf) tf = t2;
    }
    double slack = 1e-9 * (fabs(tn) + fabs(tf));
    if (isnan(slack))
        return 1;
    if (tn > tf + slack)
        return 0;
    if (tf < tmin - 1e-9 * fabs(tmin) - slack)
        return 0;
    if (tn > tmax + 1e-9 * fabs(tmax) + slack)
        return 0;
    return 1;
}

#endif

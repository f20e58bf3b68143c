/* A triangle cut by an axis plane, for the spatial splits of the high
 * build quality (build_spatial_sah.h): the part on each side is boxed by
 * the triangle's vertices on that side and the points where its edges
 * cross the plane. A crossing is computed in double and
 * padded outward by a bound on its error before it is rounded outward to
 * float, so the boxes hold the exact crossings. Inline so that the test
 * checks this code against MPFR. */
#ifndef SPHERECULL_BVH_SPLIT_TRIANGLE_H
#define SPHERECULL_BVH_SPLIT_TRIANGLE_H

#include <math.h>
#include <stdint.h>
#include <string.h>

#include "box3.h"

/* The next float below / above a finite x (libm's nextafterf is a call). */
static inline float sc_float_down(float x)
{
    uint32_t u;
    memcpy(&u, &x, 4);
    u = x > 0 ? u - 1 : x < 0 ? u + 1 : 0x80000001u;
    memcpy(&x, &u, 4);
    return x;
}
static inline float sc_float_up(float x) { return -sc_float_down(-x); }

/* [x - err, x + err] rounded outward to float. */
static inline void sc_round_outward(double x, double err, float *lo, float *hi)
{
    float l = (float)(x - err), h = (float)(x + err);
    if ((double)l > x - err && isfinite(l))
        l = sc_float_down(l);
    if ((double)h < x + err && isfinite(h))
        h = sc_float_up(h);
    *lo = l, *hi = h;
}

/* A box holding the exact point where edge ab (a[axis] < pos < b[axis], or
 * the other way round) crosses the plane x[axis] = pos. */
static inline void sc_edge_crossing(const float *a, const float *b, int axis, float pos, box3 *x)
{
    /* x = a + t (b - a), t = (pos - a) / (b - a) on the axis. Each
     * difference of two floats and the quotient are within a relative
     * 2^-53 in double, so t is within 3 * 2^-53 of itself (relative, and
     * t <= 1) and x within 2^-50 (|a| + |b|): padded by 2^-48 (|a| + |b|).
     * With denormals-are-zero a subnormal coordinate reads as 0, off by
     * less than 2^-126, which moves x by less than 2^-126 (1 + |b - a| /
     * |b - a on the axis|): padded by twice that. The exact crossing lies
     * between a and b on every axis, which bounds the pad. */
    const double da = (double)b[axis] - a[axis];
    const double t = ((double)pos - a[axis]) / da;
    for (int k = 0; k < 3; k++) {
        if (k == axis) {
            x->lo[k] = x->hi[k] = pos;
            continue;
        }
        const double dk = (double)b[k] - a[k];
        const double err = 0x1p-48 * (fabs((double)a[k]) + fabs((double)b[k])) + 0x1p-125 * (1 + fabs(dk) / fabs(da));
        sc_round_outward(a[k] + t * dk, err, &x->lo[k], &x->hi[k]);
        const float emin = a[k] < b[k] ? a[k] : b[k], emax = a[k] < b[k] ? b[k] : a[k];
        x->lo[k] = x->lo[k] > emin ? x->lo[k] : emin;
        x->hi[k] = x->hi[k] < emax ? x->hi[k] : emax;
    }
}

/* The boxes of the triangle's points in *box on each side of the plane
 * x[axis] = pos, conservative for the exact triangle whatever the
 * rounding: every point of it in *box with x[axis] <= pos lies in *left,
 * every one with x[axis] >= pos in *right. Both boxes lie in *box and on
 * their side of the plane; an empty side has lo > hi on some axis. Finite
 * vertices; pos not subnormal (with denormals-are-zero the boxes would end
 * at 0 instead: the builder never cuts there). */
static inline void sc_split_triangle(const float *const v[3], const box3 *box, int axis, float pos, box3 *left,
                                     box3 *right)
{
    box_empty(left);
    box_empty(right);
    for (int e = 0; e < 3; e++) {
        const float *a = v[e], *b = v[e == 2 ? 0 : e + 1];
        if (a[axis] <= pos)
            box_grow_point(left, a);
        if (a[axis] >= pos)
            box_grow_point(right, a);
        if ((a[axis] < pos && b[axis] > pos) || (a[axis] > pos && b[axis] < pos)) {
            box3 x;
            sc_edge_crossing(a, b, axis, pos, &x);
            box_grow(left, &x);
            box_grow(right, &x);
        }
    }
    for (int k = 0; k < 3; k++) {
        left->lo[k] = left->lo[k] > box->lo[k] ? left->lo[k] : box->lo[k];
        left->hi[k] = left->hi[k] < box->hi[k] ? left->hi[k] : box->hi[k];
        right->lo[k] = right->lo[k] > box->lo[k] ? right->lo[k] : box->lo[k];
        right->hi[k] = right->hi[k] < box->hi[k] ? right->hi[k] : box->hi[k];
    }
    left->hi[axis] = left->hi[axis] < pos ? left->hi[axis] : pos;
    right->lo[axis] = right->lo[axis] > pos ? right->lo[axis] : pos;
}

#endif

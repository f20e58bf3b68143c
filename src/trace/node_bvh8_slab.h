/* The 8-wide node test, scalar specification (the x86 kernels compute the
 * same bits on 8 lanes: node_bvh8_slab_x86.h).
 *
 * Robust slab test with one FMA per plane and no padding in the loop.
 * A slab distance is computed as t = fl(p rd - b) with rd = fl(1/d), one
 * rounding (FMA); the padding sits in b, per ray and per axis. With
 * r = 1/d, tau = (p - o) r the exact distance and M >= |p - o| for every
 * plane p of the BVH (the root box bounds every node box):
 *     p rd - b = tau + (p - o)(rd - r) + (o rd - b),   |rd - r| <= u |r|,
 * and the FMA adds at most u |p rd - b| + 2^-150. So with
 *     b_near >= o rd + D,  b_far <= o rd - D,  D >= 2u |r| M (1 + 2u) + tiny,
 * a near distance is never above tau and a far distance never below: the
 * computed interval contains the exact one, and a ray that truly meets a box
 * (whose float bounds are exact min/max of float vertices) is never culled.
 * That takes the two padding FMAs of Ize 2013 off the chain of dependent
 * operations that every node visit waits on (load, slab, max, compare,
 * child load). D is absolute: about 2^-23 of the root box's extent in t, so
 * a box is kept only when it misses the ray by less than that.
 * sc_ray_precompute (ray_setup.h) computes b. */
#ifndef SPHERECULL_TRACE_NODE_BVH8_SLAB_H
#define SPHERECULL_TRACE_NODE_BVH8_SLAB_H

#include "bvh/node_bvh8.h"
#include "ray_setup.h"

/* The node test of non-parallel rays, the specification of the SIMD ones
 * (padding: sc_ray_precompute). Near distances are lower and far distances
 * upper bounds of the exact ones, so dist[i] is a lower bound of box i's
 * exact entry distance. */
SC_TRACE_INLINE unsigned sc_slab(const sc_ray_pre *p, const sc_bvh_node8 *node, float tmin, float tmax,
                                 float *dist)
{
    unsigned mask = 0;
    for (int i = 0; i < SC_BVH_N; i++) {
        float tn[3], tf[3];
        for (int k = 0; k < 3; k++) {
            tn[k] = fmaf(node->b[p->near_row[k]][i], p->rd[k], -p->ord_near[k]);
            tf[k] = fmaf(node->b[p->far_row[k]][i], p->rd[k], -p->ord_far[k]);
        }
        float a = sc_fmax(sc_fmax(tn[0], tn[1]), sc_fmax(tn[2], tmin));
        float b = sc_fmin(sc_fmin(tf[0], tf[1]), sc_fmin(tf[2], tmax));
        dist[i] = a;
        mask |= (unsigned)(a <= b) << i;
    }
    return mask;
}

/* The node test of parallel rays (Ize 2013 with IEEE infinities): a slab
 * distance is (p - o) * (1/d) with 1/d = +-inf for d = +-0; a ray in the
 * plane of a face gives 0 * inf = NaN, which the running max/min below
 * ignore (max(a, b) = a > b ? a : b returns b when a is NaN, like (v)maxps),
 * so the closed slab contains the ray, as it should. Rounding: the distance
 * carries three roundings (difference, 1/d, product), within the 2^-21
 * relative padding; SC_SLAB_PAR_EPS covers underflow. Empty slots
 * (lo = +inf, hi = -inf) still give an empty interval. */
#define SC_SLAB_DOWN (1.0f - 0x1p-21f)
#define SC_SLAB_UP (1.0f + 0x1p-21f)
#define SC_SLAB_PAR_EPS 0x1p-122f   /* normal: survives DAZ (16 MIN of underflow) */
SC_TRACE_INLINE unsigned sc_slab_par(const sc_ray_pre *p, const sc_bvh_node8 *node, float tmin, float tmax,
                                   float *dist)
{
    unsigned mask = 0;
    for (int i = 0; i < SC_BVH_N; i++) {
        float a = tmin, b = tmax;
        for (int k = 0; k < 3; k++) {
            float tn = (node->b[p->near_row[k]][i] - p->org[k]) * p->rdp[k];
            float tf = (node->b[p->far_row[k]][i] - p->org[k]) * p->rdp[k];
            a = sc_fmax(tn, a);
            b = sc_fmin(tf, b);
        }
        a = fmaf(a, SC_SLAB_DOWN, -SC_SLAB_PAR_EPS);
        b = fmaf(b, SC_SLAB_UP, SC_SLAB_PAR_EPS);
        dist[i] = a;
        mask |= (unsigned)(a <= b) << i;
    }
    return mask;
}

#endif

/* Moller-Trumbore (1997) ray-triangle test, one lane of a leaf block: the
 * scalar specification (tri_moller_x86.h: 8 lanes, same bits). Not
 * watertight; here for comparison. */
#ifndef SPHERECULL_TRACE_TRI_MOLLER_H
#define SPHERECULL_TRACE_TRI_MOLLER_H

#include "bvh/leaf_block.h"
#include "ray_setup.h"

/* Moller-Trumbore 1997, both faces. */
SC_TRACE_INLINE int sc_tri_moller(const sc_ray_pre *p, const float *rows, unsigned W, unsigned i,
                              float tmin, float tmax, float *t, float *un, float *vn, float *den)
{
    float v0[3], e1[3], e2[3], s[3];
    for (int k = 0; k < 3; k++) {
        v0[k] = rows[sc_leaf_at(W, 0, k, i)];
        e1[k] = rows[sc_leaf_at(W, 1, k, i)] - v0[k];
        e2[k] = rows[sc_leaf_at(W, 2, k, i)] - v0[k];
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

#endif

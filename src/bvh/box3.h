/* Axis-aligned boxes of the builder: all it knows of a primitive. */
#ifndef SPHERECULL_BVH_BOX3_H
#define SPHERECULL_BVH_BOX3_H

#include <math.h>

typedef struct box3 { float lo[3], hi[3]; } box3;

static inline void box_empty(box3 *b)
{
    for (int k = 0; k < 3; k++) {
        b->lo[k] = INFINITY;
        b->hi[k] = -INFINITY;
    }
}

/* Plain compares rather than fminf/fmaxf: those are library calls at -O2
 * (NaN rules), and boxes of finite triangles hold no NaN. */
static inline void box_grow(box3 *b, const box3 *o)
{
    for (int k = 0; k < 3; k++) {
        b->lo[k] = o->lo[k] < b->lo[k] ? o->lo[k] : b->lo[k];
        b->hi[k] = o->hi[k] > b->hi[k] ? o->hi[k] : b->hi[k];
    }
}

static inline void box_grow_point(box3 *b, const float p[3])
{
    for (int k = 0; k < 3; k++) {
        b->lo[k] = p[k] < b->lo[k] ? p[k] : b->lo[k];
        b->hi[k] = p[k] > b->hi[k] ? p[k] : b->hi[k];
    }
}

static inline float box_area(const box3 *b)
{
    float d[3];
    for (int k = 0; k < 3; k++) {
        d[k] = b->hi[k] - b->lo[k];
        if (!(d[k] > 0))
            d[k] = 0;
    }
    return 2 * (d[0] * d[1] + d[1] * d[2] + d[2] * d[0]);
}

/* SAH cost of a leaf of n primitives, in leaf-block tests (4 lanes each). */
static inline float leaf_blocks(size_t n) { return (float)((n + 3) / 4); }

#endif

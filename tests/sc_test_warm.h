/* Rays that set a thread's history of ray octants (traverse_adaptive,
 * oct_history_incoherent) before a ray under test: after 16 rays of one
 * octant the next closest-hit call takes the octant kernels, after 16 of
 * changing octants the one-body kernels. */
#ifndef SC_TEST_WARM_H
#define SC_TEST_WARM_H

#include <math.h>

#include "spherecull/sc_ray.h"

/* The w-th warm-up ray: from the origin, in octant 5 (coherent) or in
 * octant w % 8 (incoherent); bit k of the octant is the sign of d_k. */
static inline sc_ray sc_test_warm_ray(int incoherent, unsigned w)
{
    const unsigned o = incoherent ? w % 8 : 5;
    const sc_ray r = { { 0, 0, 0 }, 0, { o & 1 ? -1.0f : 1.0f, o & 2 ? -0.5f : 0.5f, o & 4 ? -0.25f : 0.25f },
                       INFINITY };
    return r;
}

#endif

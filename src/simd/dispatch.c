/* Reject-mask entry points. For now they run the scalar specification lane by
 * lane; the SIMD kernel table replaces this (issue: SIMD kernels). */
#include "spherecull/sc_prefilter.h"

#define DEFINE_REJECT(W)                                                         \
    uint32_t sc_reject##W(const sc_ray *ray, const sc_sphere_block##W *b)       \
    {                                                                            \
        uint32_t mask = 0;                                                       \
        for (int i = 0; i < W; i++) {                                            \
            const float c[3] = { b->cx[i], b->cy[i], b->cz[i] };                 \
            mask |= (uint32_t)sc_ray_sphere_reject(ray, c, b->r2[i]) << i;       \
        }                                                                        \
        return mask;                                                             \
    }
DEFINE_REJECT(4)
DEFINE_REJECT(8)
DEFINE_REJECT(16)

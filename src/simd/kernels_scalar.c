/* The scalar level: the specification itself (src/sphere), one triangle or
 * sphere at a time. Fallback on every CPU and the baseline of the benchmark. */
#include <math.h>

#include "sphere_kernels.h"

#define DEFINE_SPHERES(SUF, REAL, SPHERE, SOURCE, SOA)                                        \
    static size_t spheres_##SUF##_scalar(const SOURCE *src, size_t count, int method, int kind, \
                                         unsigned flags, const SOA *out)                      \
    {                                                                                         \
        (void)flags;                                                                          \
        size_t nbad = 0;                                                                      \
        for (size_t t = 0; t < count; t++) {                                                  \
            REAL V[3][3];                                                                     \
            int bad = 0;                                                                      \
            for (int k = 0; k < 3; k++)                                                       \
                for (int ax = 0; ax < 3; ax++) {                                              \
                    if (src->indices) {                                                       \
                        uint32_t v = src->indices[3 * t + (size_t)k];                         \
                        bad |= v >= src->vertex_count;                                        \
                        V[k][ax] = bad ? 0 : src->vertices[3 * (size_t)v + (size_t)ax];       \
                    } else {                                                                  \
                        V[k][ax] = src->soa[k][ax][t];                                        \
                    }                                                                         \
                }                                                                             \
            SPHERE s;                                                                         \
            switch (kind) {                                                                   \
            case SC_BATCH_CIRCUM:                                                             \
                sc_circumsphere_##SUF(V[0], V[1], V[2], (sc_method)method,                    \
                                      SC_ORIGIN_OPPOSITE_LONGEST, &s);                        \
                break;                                                                        \
            case SC_BATCH_MINIMAL:                                                            \
                sc_minimal_sphere_##SUF(V[0], V[1], V[2], (sc_method)method,                  \
                                        SC_ORIGIN_OPPOSITE_LONGEST, &s);                      \
                break;                                                                        \
            case SC_BATCH_PREFILTER_CIRCUM:                                                   \
                sc_prefilter_sphere_##SUF(V[0], V[1], V[2], SC_SPHERE_CIRCUM, (sc_method)method, &s); \
                break;                                                                        \
            default:                                                                          \
                sc_prefilter_sphere_##SUF(V[0], V[1], V[2], SC_SPHERE_MINIMAL, (sc_method)method, &s); \
                break;                                                                        \
            }                                                                                 \
            if (bad) {                                                                        \
                nbad++;                                                                       \
                s.c[0] = s.c[1] = s.c[2] = 0;                                                 \
                s.r2 = (REAL)INFINITY;                                                        \
            }                                                                                 \
            out->cx[t] = s.c[0], out->cy[t] = s.c[1], out->cz[t] = s.c[2], out->r2[t] = s.r2; \
        }                                                                                     \
        for (size_t t = count; t < ((count + 15) & ~(size_t)15); t++)                         \
            out->cx[t] = out->cy[t] = out->cz[t] = 0, out->r2[t] = -1;                        \
        return nbad;                                                                          \
    }
DEFINE_SPHERES(f, float, sc_spheref, sc_tri_source_f, sc_spheres_soaf)
DEFINE_SPHERES(d, double, sc_sphered, sc_tri_source_d, sc_spheres_soad)

#define DEFINE_REJECT(W)                                                              \
    static uint32_t reject##W##_scalar(const sc_ray *ray, const sc_sphere_block##W *b) \
    {                                                                                 \
        uint32_t mask = 0;                                                            \
        for (int i = 0; i < W; i++) {                                                 \
            const float c[3] = { b->cx[i], b->cy[i], b->cz[i] };                      \
            mask |= (uint32_t)sc_ray_sphere_reject(ray, c, b->r2[i]) << i;            \
        }                                                                             \
        return mask;                                                                  \
    }
DEFINE_REJECT(4)
DEFINE_REJECT(8)
DEFINE_REJECT(16)

#define DEFINE_PACKET(W)                                                                        \
    static uint32_t packet##W##_scalar(const sc_ray_packet##W *p, const float c[3], float r2) \
    {                                                                                           \
        uint32_t mask = 0;                                                                      \
        for (int i = 0; i < W; i++) {                                                           \
            sc_ray ray = { { p->ox[i], p->oy[i], p->oz[i] }, p->tmin[i],                        \
                           { p->dx[i], p->dy[i], p->dz[i] }, p->tmax[i] };                      \
            mask |= (uint32_t)sc_ray_sphere_reject(&ray, c, r2) << i;                           \
        }                                                                                       \
        return mask;                                                                            \
    }
DEFINE_PACKET(8)
DEFINE_PACKET(16)

const sc_sphere_kernels sc_sphere_kernels_scalar = {
    spheres_f_scalar, spheres_d_scalar, reject4_scalar, reject8_scalar,
    reject16_scalar, packet8_scalar, packet16_scalar,
};

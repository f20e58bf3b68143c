/* The public sphere entry points (sc_simd.h, sc_prefilter.h): argument
 * checks, then the kernels of the active ISA level (src/isa). */
#include <string.h>

#include "common/sc_names.h"
#include "isa/isa_dispatch.h"
#include "simd/sphere_kernels.h"

static const char *const kind_names[SC_BATCH_KIND_COUNT] = {
    "circum", "minimal", "prefilter-circum", "prefilter-minimal",
};

const char *sc_batch_kind_name(sc_batch_kind kind)
{
    return sc_enum_name(kind_names, SC_BATCH_KIND_COUNT, (int)kind, "unknown");
}

sc_status sc_batch_kind_from_name(const char *name, sc_batch_kind *out)
{
    int v;
    if (!out || sc_enum_lookup(kind_names, SC_BATCH_KIND_COUNT, name, &v) != 0)
        return SC_ERR_INVALID_ARGUMENT;
    *out = (sc_batch_kind)v;
    return SC_OK;
}

size_t sc_simd_padded(size_t count)
{
    return (count + 15) & ~(size_t)15;
}

/* ---- public entry points ------------------------------------------------ */

uint32_t sc_reject4(const sc_ray *ray, const sc_sphere_block4 *b)
{
    return ray && b ? sc_kernels_active()->sphere->reject4(ray, b) : 0;
}

uint32_t sc_reject8(const sc_ray *ray, const sc_sphere_block8 *b)
{
    return ray && b ? sc_kernels_active()->sphere->reject8(ray, b) : 0;
}

uint32_t sc_reject16(const sc_ray *ray, const sc_sphere_block16 *b)
{
    return ray && b ? sc_kernels_active()->sphere->reject16(ray, b) : 0;
}

uint32_t sc_reject_packet8(const sc_ray_packet8 *rays, const float c[3], float r2)
{
    return rays && c ? sc_kernels_active()->sphere->packet8(rays, c, r2) : 0;
}

uint32_t sc_reject_packet16(const sc_ray_packet16 *rays, const float c[3], float r2)
{
    return rays && c ? sc_kernels_active()->sphere->packet16(rays, c, r2) : 0;
}

static int out_ok_f(const sc_spheres_soaf *o)
{
    return o && o->cx && o->cy && o->cz && o->r2;
}

static int out_ok_d(const sc_spheres_soad *o)
{
    return o && o->cx && o->cy && o->cz && o->r2;
}

static sc_status check_common(size_t count, sc_method method, sc_batch_kind kind)
{
    (void)count;
    if ((unsigned)method >= SC_METHOD_COUNT || (unsigned)kind >= SC_BATCH_KIND_COUNT)
        return SC_ERR_INVALID_ARGUMENT;
    return SC_OK;
}

#define DEFINE_INDEXED(SUF, REAL)                                                                  \
    sc_status sc_spheres_indexed_##SUF(const REAL *vertices, size_t vertex_count,                 \
                                       const uint32_t *indices, size_t count, sc_method method,   \
                                       sc_batch_kind kind, const sc_spheres_soa##SUF *out)        \
    {                                                                                              \
        if (!out_ok_##SUF(out) || check_common(count, method, kind) != SC_OK ||                    \
            (count && (!indices || (vertex_count && !vertices))))                                  \
            return SC_ERR_INVALID_ARGUMENT;                                                        \
        if (vertex_count > SC_SIMD_MAX_VERTICES)                                                   \
            return SC_ERR_LIMIT;                                                                   \
        sc_tri_source_##SUF src = { vertices, vertex_count, indices, { { 0 } } };                 \
        /* With no vertices every index is out of range; the scalar loop says so without        \
         * the gathers' clamp to vertex_count - 1. */                                              \
        const sc_sphere_kernels *k = vertex_count ? sc_kernels_active()->sphere : &sc_sphere_kernels_scalar;             \
        size_t bad = k->spheres_##SUF(&src, count, (int)method, (int)kind, 0, out);                \
        return bad ? SC_ERR_INVALID_ARGUMENT : SC_OK;                                              \
    }                                                                                              \
    sc_status sc_spheres_soa_##SUF(const sc_triangles_soa##SUF *tri, size_t count,                \
                                   sc_method method, sc_batch_kind kind,                          \
                                   const sc_spheres_soa##SUF *out)                                \
    {                                                                                              \
        if (!out_ok_##SUF(out) || !tri || check_common(count, method, kind) != SC_OK)             \
            return SC_ERR_INVALID_ARGUMENT;                                                        \
        sc_tri_source_##SUF src = { NULL, 0, NULL, { { 0 } } };                                   \
        for (int v = 0; v < 3; v++) {                                                              \
            src.soa[v][0] = tri->x[v], src.soa[v][1] = tri->y[v], src.soa[v][2] = tri->z[v];       \
            if (count && (!tri->x[v] || !tri->y[v] || !tri->z[v]))                                 \
                return SC_ERR_INVALID_ARGUMENT;                                                    \
        }                                                                                          \
        sc_kernels_active()->sphere->spheres_##SUF(&src, count, (int)method, (int)kind, 0, out);          \
        return SC_OK;                                                                              \
    }
DEFINE_INDEXED(f, float)
DEFINE_INDEXED(d, double)

/* Run-time dispatch: one kernel table, chosen once (widest level the CPU
 * supports, or SPHERECULL_ISA), published with an atomic pointer so that
 * concurrent first calls are safe; every public SIMD entry point goes
 * through it. */
#include <stdlib.h>
#include <string.h>

#include "sc_kernels.h"
#include "x86/cpu_features.h"

static const char *const isa_names[SC_ISA_COUNT] = { "scalar", "sse4", "avx2", "avx512" };
static const char *const kind_names[SC_BATCH_KIND_COUNT] = {
    "circum", "minimal", "prefilter-circum", "prefilter-minimal",
};

const char *sc_isa_name(sc_isa isa)
{
    return (unsigned)isa < SC_ISA_COUNT ? isa_names[isa] : "unknown";
}

sc_status sc_isa_from_name(const char *name, sc_isa *out)
{
    if (!name || !out)
        return SC_ERR_INVALID_ARGUMENT;
    for (int i = 0; i < SC_ISA_COUNT; i++)
        if (strcmp(name, isa_names[i]) == 0) {
            *out = (sc_isa)i;
            return SC_OK;
        }
    return SC_ERR_INVALID_ARGUMENT;
}

const char *sc_batch_kind_name(sc_batch_kind kind)
{
    return (unsigned)kind < SC_BATCH_KIND_COUNT ? kind_names[kind] : "unknown";
}

sc_status sc_batch_kind_from_name(const char *name, sc_batch_kind *out)
{
    if (!name || !out)
        return SC_ERR_INVALID_ARGUMENT;
    for (int i = 0; i < SC_BATCH_KIND_COUNT; i++)
        if (strcmp(name, kind_names[i]) == 0) {
            *out = (sc_batch_kind)i;
            return SC_OK;
        }
    return SC_ERR_INVALID_ARGUMENT;
}

int sc_isa_supported(sc_isa isa)
{
    return sc_kernels_for(isa) != NULL;
}

const sc_kernels *sc_kernels_for(sc_isa isa)
{
    switch (isa) {
    case SC_ISA_SCALAR:
        return &sc_kernels_scalar;
#if defined(__x86_64__) || defined(__i386__)
    case SC_ISA_SSE4:
        return (sc_x86_features() & SC_X86_SSE41) ? &sc_kernels_sse4 : NULL;
    case SC_ISA_AVX2: {
        uint32_t need = SC_X86_SSE41 | SC_X86_AVX | SC_X86_AVX2 | SC_X86_FMA;
        return (sc_x86_features() & need) == need ? &sc_kernels_avx2 : NULL;
    }
    case SC_ISA_AVX512: {
        uint32_t need = SC_X86_SSE41 | SC_X86_AVX | SC_X86_AVX2 | SC_X86_FMA | SC_X86_AVX512F |
                        SC_X86_AVX512VL | SC_X86_AVX512DQ;
        return (sc_x86_features() & need) == need ? &sc_kernels_avx512 : NULL;
    }
#endif
    default:
        return NULL;
    }
}

static const sc_kernels *active;      /* accessed atomically */
static int init_status = -1;          /* accessed atomically; -1 = not yet */

static const sc_kernels *best(void)
{
    for (int i = SC_ISA_COUNT - 1; i > 0; i--)
        if (sc_kernels_for((sc_isa)i))
            return sc_kernels_for((sc_isa)i);
    return &sc_kernels_scalar;
}

/* Deterministic, so racing threads agree; the first store wins. */
static const sc_kernels *choose(sc_status *st)
{
    const char *env = getenv("SPHERECULL_ISA");
    *st = SC_OK;
    if (!env || !*env)
        return best();
    sc_isa isa;
    if (sc_isa_from_name(env, &isa) != SC_OK) {
        *st = SC_ERR_INVALID_ARGUMENT;
        return best();
    }
    const sc_kernels *k = sc_kernels_for(isa);
    if (!k) {
        *st = SC_ERR_UNSUPPORTED;
        return best();
    }
    return k;
}

sc_status sc_simd_init(void)
{
    int st = __atomic_load_n(&init_status, __ATOMIC_ACQUIRE);
    if (st >= 0)
        return (sc_status)st;
    sc_status s;
    const sc_kernels *k = choose(&s);
    const sc_kernels *expected = NULL;
    __atomic_compare_exchange_n(&active, &expected, k, 0, __ATOMIC_ACQ_REL, __ATOMIC_ACQUIRE);
    int unset = -1;
    __atomic_compare_exchange_n(&init_status, &unset, (int)s, 0, __ATOMIC_ACQ_REL, __ATOMIC_ACQUIRE);
    return (sc_status)__atomic_load_n(&init_status, __ATOMIC_ACQUIRE);
}

const sc_kernels *sc_kernels_active(void)
{
    const sc_kernels *k = __atomic_load_n(&active, __ATOMIC_ACQUIRE);
    if (k)
        return k;
    sc_simd_init();
    return __atomic_load_n(&active, __ATOMIC_ACQUIRE);
}

sc_isa sc_isa_active(void)
{
    return sc_kernels_active()->isa;
}

sc_status sc_isa_force(sc_isa isa)
{
    const sc_kernels *k = sc_kernels_for(isa);
    if (!k)
        return (unsigned)isa < SC_ISA_COUNT ? SC_ERR_UNSUPPORTED : SC_ERR_INVALID_ARGUMENT;
    sc_simd_init();
    __atomic_store_n(&active, k, __ATOMIC_RELEASE);
    return SC_OK;
}

size_t sc_simd_padded(size_t count)
{
    return (count + 15) & ~(size_t)15;
}

/* ---- public entry points ------------------------------------------------ */

uint32_t sc_reject4(const sc_ray *ray, const sc_sphere_block4 *b)
{
    return ray && b ? sc_kernels_active()->reject4(ray, b) : 0;
}

uint32_t sc_reject8(const sc_ray *ray, const sc_sphere_block8 *b)
{
    return ray && b ? sc_kernels_active()->reject8(ray, b) : 0;
}

uint32_t sc_reject16(const sc_ray *ray, const sc_sphere_block16 *b)
{
    return ray && b ? sc_kernels_active()->reject16(ray, b) : 0;
}

uint32_t sc_reject_packet8(const sc_ray_packet8 *rays, const float c[3], float r2)
{
    return rays && c ? sc_kernels_active()->packet8(rays, c, r2) : 0;
}

uint32_t sc_reject_packet16(const sc_ray_packet16 *rays, const float c[3], float r2)
{
    return rays && c ? sc_kernels_active()->packet16(rays, c, r2) : 0;
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
        const sc_kernels *k = vertex_count ? sc_kernels_active() : &sc_kernels_scalar;             \
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
        sc_kernels_active()->spheres_##SUF(&src, count, (int)method, (int)kind, 0, out);          \
        return SC_OK;                                                                              \
    }
DEFINE_INDEXED(f, float)
DEFINE_INDEXED(d, double)

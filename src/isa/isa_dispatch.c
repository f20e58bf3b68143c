/* Run-time dispatch: one kernel table per ISA level holding the sphere
 * kernels (src/simd) and the traversal kernels (src/trace) of that level,
 * chosen once (the widest level the CPU supports, or SPHERECULL_ISA) and
 * published with an atomic pointer, so concurrent first calls are safe and
 * sc_isa_force switches everything together. */
#include <stdlib.h>
#include <string.h>

#include "common/sc_names.h"
#include "isa_dispatch.h"
#include "x86/cpu_features.h"

static const char *const isa_names[SC_ISA_COUNT] = { "scalar", "sse4", "avx2", "avx512" };

const char *sc_isa_name(sc_isa isa)
{
    return sc_enum_name(isa_names, SC_ISA_COUNT, (int)isa, "unknown");
}

sc_status sc_isa_from_name(const char *name, sc_isa *out)
{
    int v;
    if (!out || sc_enum_lookup(isa_names, SC_ISA_COUNT, name, &v) != 0)
        return SC_ERR_INVALID_ARGUMENT;
    *out = (sc_isa)v;
    return SC_OK;
}

static const sc_kernels kernels_scalar = { SC_ISA_SCALAR, &sc_sphere_kernels_scalar, sc_trace_kernels_scalar };
#if defined(__x86_64__) || defined(__i386__)
/* The traversal has no SSE4.1 kernels: at that level it runs the scalar ones. */
static const sc_kernels kernels_sse4 = { SC_ISA_SSE4, &sc_sphere_kernels_sse4, sc_trace_kernels_scalar };
static const sc_kernels kernels_avx2 = { SC_ISA_AVX2, &sc_sphere_kernels_avx2, sc_trace_kernels_avx2 };
static const sc_kernels kernels_avx512 = { SC_ISA_AVX512, &sc_sphere_kernels_avx512, sc_trace_kernels_avx512 };

/* What each level's kernels are compiled for (their target attributes). */
#define NEED_SSE4 SC_X86_SSE41
#define NEED_AVX2 (NEED_SSE4 | SC_X86_POPCNT | SC_X86_AVX | SC_X86_AVX2 | SC_X86_FMA | SC_X86_BMI1 | SC_X86_BMI2 | \
                   SC_X86_LZCNT)
#define NEED_AVX512 (NEED_AVX2 | SC_X86_AVX512F | SC_X86_AVX512VL | SC_X86_AVX512DQ | SC_X86_AVX512BW)
#endif

int sc_isa_supported(sc_isa isa)
{
    return sc_kernels_for(isa) != NULL;
}

const sc_kernels *sc_kernels_for(sc_isa isa)
{
#if defined(__x86_64__) || defined(__i386__)
    const uint32_t f = sc_x86_features();
#endif
    switch (isa) {
    case SC_ISA_SCALAR:
        return &kernels_scalar;
#if defined(__x86_64__) || defined(__i386__)
    case SC_ISA_SSE4:
        return (f & NEED_SSE4) == NEED_SSE4 ? &kernels_sse4 : NULL;
    case SC_ISA_AVX2:
        return (f & NEED_AVX2) == NEED_AVX2 ? &kernels_avx2 : NULL;
    case SC_ISA_AVX512:
        return (f & NEED_AVX512) == NEED_AVX512 ? &kernels_avx512 : NULL;
#endif
    default:
        return NULL;
    }
}

const sc_kernels *sc_kernels_active_ptr;   /* accessed atomically */
static int init_status = -1;          /* accessed atomically; -1 = not yet */

static const sc_kernels *best(void)
{
    for (int i = SC_ISA_COUNT - 1; i > 0; i--)
        if (sc_kernels_for((sc_isa)i))
            return sc_kernels_for((sc_isa)i);
    return &kernels_scalar;
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
    __atomic_compare_exchange_n(&sc_kernels_active_ptr, &expected, k, 0, __ATOMIC_ACQ_REL, __ATOMIC_ACQUIRE);
    int unset = -1;
    __atomic_compare_exchange_n(&init_status, &unset, (int)s, 0, __ATOMIC_ACQ_REL, __ATOMIC_ACQUIRE);
    return (sc_status)__atomic_load_n(&init_status, __ATOMIC_ACQUIRE);
}

const sc_kernels *sc_kernels_first_use(void)
{
    sc_simd_init();
    return __atomic_load_n(&sc_kernels_active_ptr, __ATOMIC_ACQUIRE);
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
    __atomic_store_n(&sc_kernels_active_ptr, k, __ATOMIC_RELEASE);
    return SC_OK;
}


/* Public entry points: argument checks, then the kernel set chosen at build
 * time. A NULL stats pointer selects the kernel compiled without counters. */
#include <stdlib.h>
#include <string.h>

#include "trace_common.h"

int sc_trace_isa_supported(sc_trace_isa isa)
{
    switch (isa) {
    case SC_TRACE_ISA_AUTO:
    case SC_TRACE_ISA_SCALAR:
        return 1;
#if defined(__x86_64__) || defined(__i386__)
    case SC_TRACE_ISA_AVX2:
        __builtin_cpu_init();
        return __builtin_cpu_supports("avx2") && __builtin_cpu_supports("fma") &&
               __builtin_cpu_supports("bmi2");
    case SC_TRACE_ISA_AVX512:
        __builtin_cpu_init();
        return sc_trace_isa_supported(SC_TRACE_ISA_AVX2) && __builtin_cpu_supports("avx512f") &&
               __builtin_cpu_supports("avx512vl") && __builtin_cpu_supports("avx512bw") &&
               __builtin_cpu_supports("avx512dq");
#endif
    default:
        return 0;
    }
}

sc_status sc_trace_select(sc_trace_isa want, sc_trace_isa *got)
{
    if ((unsigned)want >= SC_TRACE_ISA_COUNT || !got)
        return SC_ERR_INVALID_ARGUMENT;
    if (want == SC_TRACE_ISA_AUTO) {
        const char *env = getenv("SPHERECULL_ISA");
        if (env && *env) {
            /* The project-wide names; sse4 has no kernel of its own here. */
            if (strcmp(env, "scalar") == 0 || strcmp(env, "sse4") == 0)
                want = SC_TRACE_ISA_SCALAR;
            else if (strcmp(env, "avx2") == 0)
                want = SC_TRACE_ISA_AVX2;
            else if (strcmp(env, "avx512") == 0)
                want = SC_TRACE_ISA_AVX512;
        }
    }
    if (want == SC_TRACE_ISA_AUTO) {
        want = sc_trace_isa_supported(SC_TRACE_ISA_AVX512) ? SC_TRACE_ISA_AVX512
               : sc_trace_isa_supported(SC_TRACE_ISA_AVX2) ? SC_TRACE_ISA_AVX2
                                                           : SC_TRACE_ISA_SCALAR;
    }
    if (!sc_trace_isa_supported(want))
        return SC_ERR_UNSUPPORTED;
    *got = want;
    return SC_OK;
}

sc_status sc_trace_closest(const sc_bvh *bvh, const sc_ray *ray, sc_hitrec *hit, sc_trace_stats *stats)
{
    if (!bvh || !ray || !hit || !sc_ray_valid(ray))
        return SC_ERR_INVALID_ARGUMENT;
    if (stats)
        bvh->kernels->closest_stats(bvh, ray, hit, stats);
    else
        bvh->kernels->closest(bvh, ray, hit);
    return SC_OK;
}

sc_status sc_trace_any(const sc_bvh *bvh, const sc_ray *ray, int *occluded, sc_trace_stats *stats)
{
    if (!bvh || !ray || !occluded || !sc_ray_valid(ray))
        return SC_ERR_INVALID_ARGUMENT;
    *occluded = stats ? bvh->kernels->any_stats(bvh, ray, stats) : bvh->kernels->any(bvh, ray);
    return SC_OK;
}

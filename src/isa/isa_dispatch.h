/* The one kernel table per ISA level: sphere kernels and traversal kernels
 * of the same level, switched together (sc_isa.h). Private to the library,
 * the tests and the benchmarks. */
#ifndef SPHERECULL_ISA_DISPATCH_H
#define SPHERECULL_ISA_DISPATCH_H

#include "simd/sphere_kernels.h"
#include "spherecull/sc_isa.h"
#include "trace/trace_kernels.h"

typedef struct sc_kernels {
    sc_isa isa;
    const sc_sphere_kernels *sphere;
    const sc_trace_kernels *trace;    /* [sc_tri_test] */
} sc_kernels;

/* The table for a level, or NULL if the build or CPU lacks it. */
const sc_kernels *sc_kernels_for(sc_isa isa);
/* The active table (initializes on first call). Inline because every
 * public trace and reject call starts with it: one acquire load (a plain
 * load on x86) once the choice is made. Take it once per call, so that a
 * concurrent sc_isa_force cannot mix levels within one call. */
extern const sc_kernels *sc_kernels_active_ptr;
const sc_kernels *sc_kernels_first_use(void);
static inline const sc_kernels *sc_kernels_active(void)
{
    const sc_kernels *k = __atomic_load_n(&sc_kernels_active_ptr, __ATOMIC_ACQUIRE);
    return __builtin_expect(k != NULL, 1) ? k : sc_kernels_first_use();
}

#endif

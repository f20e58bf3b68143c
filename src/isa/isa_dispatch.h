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
/* The active table (initializes on first call). One atomic load: take it
 * once per call so that a concurrent sc_isa_force cannot mix levels. */
const sc_kernels *sc_kernels_active(void);

#endif

/* spherecull — the instruction-set level every kernel runs at.
 *
 * One choice for the whole library: batch spheres, the sc_reject4/8/16 and
 * packet masks (sc_prefilter.h, sc_simd.h) and the BVH traversal
 * (sc_trace.h) switch together. On first use the library picks the widest
 * level this CPU (and OS, via XGETBV) supports, or the level named by the
 * environment variable SPHERECULL_ISA=scalar|sse4|avx2|avx512; the choice
 * is made once, thread-safely. The traversal has no SSE4.1 kernels of its
 * own: at that level it runs the scalar ones. Every level returns the same
 * hits bit for bit; spheres built with FMA (AVX2, AVX-512) differ in the
 * last bits but keep every guarantee (sc_simd.h).
 *
 * The library never prints: call sc_simd_init() to learn whether
 * SPHERECULL_ISA was honoured.
 *
 * Threads. The kernel table is one process-wide pointer, published
 * atomically: racing first uses from many threads agree on one choice, and
 * every kernel may run from any number of threads at once (each public call
 * reads the table once). SPHERECULL_ISA is read once, at that first use.
 * sc_isa_force is global too: it is itself free of data races, but a call
 * running concurrently may finish on the old level, and since AVX2/AVX-512
 * batch spheres differ from the others in the last bits (FMA), call it
 * before starting threads (or while none runs a kernel) if results must not
 * mix. Traced hits are the same on every level.
 */
#ifndef SPHERECULL_SC_ISA_H
#define SPHERECULL_SC_ISA_H

#include "sc_api.h"
#include "sc_status.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef enum sc_isa {
    SC_ISA_SCALAR = 0,  /* the scalar specification, any CPU */
    SC_ISA_SSE4,        /* SSE4.1, 4 float / 2 double lanes */
    SC_ISA_AVX2,        /* AVX2 + FMA (+ BMI1/2, LZCNT, POPCNT), 8 / 4 lanes */
    SC_ISA_AVX512,      /* AVX-512 F + VL + DQ + BW, 16 / 8 lanes */
    SC_ISA_COUNT
} sc_isa;

/* "scalar", "sse4", "avx2", "avx512"; inverse returns SC_ERR_INVALID_ARGUMENT
 * for an unknown name. */
SC_API const char *sc_isa_name(sc_isa isa);
SC_API sc_status sc_isa_from_name(const char *name, sc_isa *out);

/* 1 if this build has the level and this CPU and OS can run it. */
SC_API int sc_isa_supported(sc_isa isa);

/* Chooses the kernel table (once; later calls return the first result).
 * SC_OK: SPHERECULL_ISA unset or honoured. SC_ERR_INVALID_ARGUMENT: unknown
 * name. SC_ERR_UNSUPPORTED: the CPU or build lacks the named level. In both
 * error cases the kernels run at the widest supported level. */
SC_API sc_status sc_simd_init(void);

/* The level the kernels run at (initializes on first call). */
SC_API sc_isa sc_isa_active(void);

/* Switches every kernel to `isa` (for tests, benchmarks and the CLI's --isa).
 * The switch is atomic: a call running on another thread finishes with the
 * level it started with. SC_ERR_UNSUPPORTED if the CPU or build lacks it
 * (the active level is then unchanged). */
SC_API sc_status sc_isa_force(sc_isa isa);

#ifdef __cplusplus
}
#endif
#endif

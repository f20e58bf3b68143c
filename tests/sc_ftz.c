/* See sc_ftz.h. Linked into every test executable; a no-op unless
 * SPHERECULL_TEST_FTZ=1. */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#ifdef _OPENMP
#include <omp.h>
#endif

#include "sc_ftz.h"

int sc_test_ftz_requested(void)
{
    const char *e = getenv("SPHERECULL_TEST_FTZ");
    return e && strcmp(e, "1") == 0;
}

void sc_test_ftz_thread_init(void)
{
    unsigned csr = _mm_getcsr() & ~(SC_MXCSR_FTZ | SC_MXCSR_DAZ);
    if (sc_test_ftz_requested())
        csr |= SC_MXCSR_FTZ | SC_MXCSR_DAZ;
    _mm_setcsr(csr);
}

__attribute__((constructor)) static void sc_test_ftz_startup(void)
{
    if (!sc_test_ftz_requested())
        return;
    sc_test_ftz_thread_init();
    int bad = 0;
#ifdef _OPENMP
    /* Every worker of the pool the library's parallel regions reuse. */
#pragma omp parallel reduction(+ : bad)
    {
        sc_test_ftz_thread_init();
        bad += !sc_test_ftz_active();
    }
#endif
    /* The mode must be real, not just the bits: a subnormal product flushes,
     * a subnormal operand reads as zero. */
    volatile float tiny = 0x1p-126f, half = 0.5f, sub = 0x1p-140f;
    if (tiny * half != 0.0f || sub + 0.0f != 0.0f || !sc_test_ftz_active())
        bad++;
    if (bad) {
        fprintf(stderr, "sc_ftz: could not set FTZ|DAZ\n");
        abort();
    }
    fprintf(stderr, "sc_ftz: MXCSR FTZ|DAZ on (SPHERECULL_TEST_FTZ=1)\n");
}

/* Test helper: the MXCSR flush-to-zero / denormals-are-zero mode.
 *
 * Renderers (and Embree's documentation) set FTZ|DAZ in every thread, so
 * every bound this library states must hold with the bits on and off. Each
 * test linked with tests/sc_ftz.c reads SPHERECULL_TEST_FTZ at start-up: "1"
 * sets FTZ|DAZ in the main thread and in every OpenMP worker before main()
 * runs (tests/CMakeLists.txt registers the numerics tests once per mode).
 * Threads a test creates itself inherit the main thread's MXCSR on Linux;
 * they call sc_test_ftz_thread_init() anyway, so the mode never depends on
 * that. */
#ifndef SC_TEST_FTZ_H
#define SC_TEST_FTZ_H

#include <xmmintrin.h>

#define SC_MXCSR_FTZ 0x8000u
#define SC_MXCSR_DAZ 0x0040u

/* 1 when SPHERECULL_TEST_FTZ=1 asked for FTZ|DAZ. */
int sc_test_ftz_requested(void);

/* Sets the requested mode in the calling thread. */
void sc_test_ftz_thread_init(void);

/* 1 when the calling thread runs with FTZ|DAZ set (read from MXCSR). */
static inline int sc_test_ftz_active(void)
{
    return (_mm_getcsr() & (SC_MXCSR_FTZ | SC_MXCSR_DAZ)) == (SC_MXCSR_FTZ | SC_MXCSR_DAZ);
}

/* 1 when the calling thread runs in the requested mode. */
static inline int sc_test_ftz_thread_ok(void)
{
    return sc_test_ftz_active() == sc_test_ftz_requested();
}

/* Test inputs and references are computed with gradual underflow, so that
 * only the code under test runs in the requested mode: a generator that
 * rounds a double to float would otherwise flush subnormal inputs before the
 * library ever sees them.
 *   unsigned saved = sc_test_ftz_off();  ...generate...  sc_test_ftz_restore(saved); */
static inline unsigned sc_test_ftz_off(void)
{
    unsigned saved = _mm_getcsr();
    _mm_setcsr(saved & ~(SC_MXCSR_FTZ | SC_MXCSR_DAZ));
    return saved;
}
static inline void sc_test_ftz_restore(unsigned saved)
{
    _mm_setcsr(saved);
}

#endif
